// The figures of docs/view.md for esfleet-view, measured on this host (loopback):
//   A. CSAIL: a leader maps the whole log at --rate times the recorded speed while one browser
//      (headless chromium) watches: bytes per log second to the browser against sending the
//      whole map at the same times, tile publish -> pixels latency (median, p99), and the time
//      from opening the page to the whole map (5 fresh pages once the map is complete);
//   B. a simulated fleet of --robots robots (esfleet-fleet) with --clients WebSocket clients:
//      esfleet-view's CPU and memory while they watch.
// Prints the figures and writes them to --out (JSON).
//
// usage: node --experimental-websocket bench/view_bench.mjs [--rate 4] [--robots 64]
//          [--clients 20] [--fleet-seconds 30] [--out out/view-bench.json] [--skip-fleet]
//          [--skip-csail]
// Needs build/bin (esfleet-view, -leader, -fleet, -follower, -sim), Debian's chromium and
// playwright-core in build/node (npm install --prefix build/node playwright-core@1.65.1).
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';

const args = Object.fromEntries(process.argv.slice(2).reduce((a, v, i, all) => {
  if (v.startsWith('--')) a.push([v.slice(2), all[i + 1] && !all[i + 1].startsWith('--') ? all[i + 1] : true]);
  return a;
}, []));
const project = path.resolve(path.dirname(new URL(import.meta.url).pathname), '..');
const bin = path.join(project, 'build/bin');
const rate = Number(args.rate ?? 4);
const robots = Number(args.robots ?? 64);
const clients = Number(args.clients ?? 20);
const fleetSeconds = Number(args['fleet-seconds'] ?? 30);  // the measuring window
const outFile = path.resolve(args.out ?? path.join(project, 'out/view-bench.json'));
const require = createRequire(path.join(project, 'build/node/node_modules/x.js'));
const { chromium } = require('playwright-core');
const work = fs.mkdtempSync(path.join(os.tmpdir(), 'esfleet-view-bench.'));
const profile = path.join(project, 'deploy/fastdds/localhost-udp.xml');
const log = path.join(project, 'data/mit-csail/mit-csail.clf.gz');

const children = [];
function start(name, argv) {
  const out = fs.openSync(path.join(work, `${name}.log`), 'w');
  const p = spawn(path.join(bin, argv[0]), argv.slice(1), { stdio: ['ignore', out, out], cwd: project });
  p.exited = new Promise((r) => p.on('exit', (code) => r(code)));
  children.push(p);
  return p;
}
async function stop(p) {
  if (p.exitCode !== null || p.signalCode !== null) return;
  p.kill('SIGINT');
  const t = setTimeout(() => p.kill('SIGKILL'), 40000);
  await p.exited;
  clearTimeout(t);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(what, seconds, pred) {
  const end = Date.now() + seconds * 1000;
  for (;;) {
    const v = await pred();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await sleep(200);
  }
}
const quantile = (v, q) => { const s = [...v].sort((a, b) => a - b); return s[Math.min(s.length - 1, Math.floor(q * s.length))]; };
const json = async (url) => (await fetch(url)).json();
function procStat(pid) {
  const stat = fs.readFileSync(`/proc/${pid}/stat`, 'utf8');
  const f = stat.slice(stat.lastIndexOf(')') + 2).split(' ');
  const status = fs.readFileSync(`/proc/${pid}/status`, 'utf8');
  const kb = (k) => Number(new RegExp(`${k}:\\s+(\\d+)`).exec(status)[1]);
  return { cpu_s: (Number(f[11]) + Number(f[12])) / 100, rss_mb: kb('VmRSS') / 1024, hwm_mb: kb('VmHWM') / 1024 };
}

// A part skipped keeps its figures from an earlier run in --out.
const earlier = fs.existsSync(outFile) ? JSON.parse(fs.readFileSync(outFile, 'utf8')) : {};
const figures = { ...earlier, date: new Date().toISOString(), host: os.hostname(),
                  cpus: os.cpus().length, load_before: os.loadavg()[0] };
const browser = await chromium.launch({ executablePath: '/usr/bin/chromium', args: ['--no-sandbox'] });
try {
  // ---------------------------------------------------------------- A. CSAIL, one browser
  if (!args['skip-csail']) {
    const domain = '91', port = '18091', url = `http://127.0.0.1:${port}/`;
    const dds = ['--domain', domain, '--profile', profile];
    const view = start('view-a', ['esfleet-view', ...dds, '--port', port, '--bind', '127.0.0.1']);
    await sleep(1000);
    const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
    await page.goto(url);
    await until('connected', 10, () => page.evaluate(() => window.esfleetView.state().connected));
    const leaderOut = path.join(work, 'leader');
    const leader = start('leader-a', ['esfleet-leader', '--log', log, '--odometry', 'on', '--rate',
                                      String(rate), ...dds, '--out', leaderOut, '--linger', '-1']);
    const t0 = Date.now();
    await until('the leader\'s whole log', 3600, () => fs.existsSync(path.join(leaderOut, 'stats.json')));
    await until('the complete map in the browser', 60, () => page.evaluate(() => {
      const s = window.esfleetView.state();
      return s.status && s.status.complete && s.tiles === s.status.tiles;
    }));
    const mapping_s = (Date.now() - t0) / 1000;
    const traj = fs.readFileSync(path.join(leaderOut, 'trajectory.txt'), 'utf8').trim().split('\n');
    const logSeconds = Number(traj.at(-1).split(/\s+/)[0]) - Number(traj[0].split(/\s+/)[0]);
    const st = await json(`${url}stats.json`);
    const pageState = await page.evaluate(() => window.esfleetView.state());
    const tiles = await page.evaluate(() => window.esfleetView.tileLog());
    const matched = Math.min(...tiles.map((t) => t.recv_ms));
    const lat = tiles.filter((t) => t.drawn_ms !== null && t.stamp_ms >= matched)
      .map((t) => t.drawn_ms - t.stamp_ms);
    const f = st.forwarded;
    figures.csail = {
      leader_rate: rate, scans: traj.length, log_seconds: logSeconds, wall_seconds: mapping_s,
      tiles: pageState.tiles,
      browser_bytes: pageState.bytes,
      browser_bytes_per_log_s: pageState.bytes / logSeconds,
      tile_frames_bytes: f.bytes, tile_frames_sent: f.tiles, leader_publishes: f.leader_publishes,
      whole_map_frames_bytes: f.whole_map_frame_bytes,
      whole_map_frames_per_log_s: f.whole_map_frame_bytes / logSeconds,
      whole_map_grid_bytes: f.whole_map_grid_bytes,
      whole_map_grid_per_log_s: f.whole_map_grid_bytes / logSeconds,
      ratio_frames: f.whole_map_frame_bytes / f.bytes,
      ratio_grid: f.whole_map_grid_bytes / f.bytes,
      latency_ms: { n: lat.length, median: quantile(lat, 0.5), p99: quantile(lat, 0.99), max: Math.max(...lat) },
      forward_latency_ms: f.latency_ms,
      dds_bytes_received: st.dds.bytes_received,
    };
    // Open the page afresh: time to the whole map (loopback), five times.
    const opens = [];
    for (let i = 0; i < 5; ++i) {
      const p = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
      const t = Date.now();
      await p.goto(url);
      await until('the whole map', 30, () => p.evaluate(() => window.esfleetView.state().wholeMapAt !== null));
      opens.push((await p.evaluate(() => window.esfleetView.state().wholeMapAt)) - t);
      await p.close();
    }
    figures.csail.open_to_whole_map_ms = { runs: opens, median: quantile(opens, 0.5), max: Math.max(...opens) };
    await page.close();
    await stop(leader);
    await stop(view);
    console.log(JSON.stringify(figures.csail, null, 2));
  }

  // ---------------------------------------------------------------- B. fleet + N clients
  if (!args['skip-fleet']) {
    // Shared memory, the launcher's default: the UDP loopback profile announces discovery to
    // the first 32 participant ids only (deploy/fastdds/localhost-udp.xml), too few for 64.
    const shm = path.join(project, 'tests/fastdds/localhost-shm.xml');
    const domain = '92', port = '18092', url = `http://127.0.0.1:${port}/`;
    const dds = ['--domain', domain, '--profile', shm];
    const view = start('view-b', ['esfleet-view', ...dds, '--port', port, '--bind', '127.0.0.1']);
    // --wait-map: the leader maps the log first, then the simulator and the followers start
    // (a fleet joining a mapped building, as in docs/benchmarks.md's fleet scale runs).
    const fleet = start('fleet', ['esfleet-fleet', '--robots', String(robots), '--duration', '0',
                                  '--wait-map', '--domain', domain, '--profile', shm,
                                  '--out', path.join(work, 'fleet'), '--live', 'false']);
    await until('the complete map', 600, async () => {
      try { return (await json(`${url}status.json`)).complete; } catch { return false; }
    });
    const robotsUp = await until('every robot', 180, async () => {
      const r = (await json(`${url}robots.json`)).robots;
      return r.filter((q) => !q.leader).length >= robots ? r : null;
    }).catch(() => null);
    const socks = [];
    const got = new Array(clients).fill(0);
    for (let i = 0; i < clients; ++i) {
      const ws = new WebSocket(`ws://127.0.0.1:${port}/ws`);
      ws.binaryType = 'arraybuffer';
      ws.onmessage = (ev) => { got[i] += typeof ev.data === 'string' ? ev.data.length : ev.data.byteLength; };
      socks.push(ws);
    }
    await sleep(5000);
    const a = procStat(view.pid), gotA = got.reduce((x, y) => x + y, 0), tA = Date.now();
    const robotsA = (await json(`${url}robots.json`)).robots.length;
    await sleep(fleetSeconds * 1000);
    const b = procStat(view.pid), gotB = got.reduce((x, y) => x + y, 0), tB = Date.now();
    const st = await json(`${url}stats.json`);
    const robotsB = (await json(`${url}robots.json`)).robots;
    figures.fleet = {
      robots, clients, window_s: (tB - tA) / 1000,
      all_robots_up: robotsUp !== null, robots_seen: robotsB.length,
      robots_seen_at_window_start: robotsA,
      tracking: robotsB.filter((r) => r.status === 'tracking').length,
      view_cpu_percent: (100 * (b.cpu_s - a.cpu_s)) / ((tB - tA) / 1000),
      view_rss_mb: b.rss_mb, view_peak_rss_mb: b.hwm_mb,
      bytes_per_client_per_s: (gotB - gotA) / clients / ((tB - tA) / 1000),
      clients_connected: st.server.clients, dropped: st.server.dropped,
      load_average: os.loadavg()[0],
    };
    for (const ws of socks) ws.close();
    await stop(fleet);
    await stop(view);
    console.log(JSON.stringify(figures.fleet, null, 2));
  }
} finally {
  await browser.close();
  for (const c of children) await stop(c);
}
fs.mkdirSync(path.dirname(outFile), { recursive: true });
fs.writeFileSync(outFile, JSON.stringify(figures, null, 2));
console.log(`figures written to ${outFile}`);
fs.rmSync(work, { recursive: true, force: true });
