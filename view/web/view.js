// esfleet view: the page. Plain JavaScript, no framework, no build step; served by esfleet-view
// from the copy embedded in the program. The protocol (docs/view.md): one WebSocket on /ws;
// binary frames are tiles (a 44-byte little-endian header, then the tile's cell classes,
// zlib-compressed), text frames are JSON states ("map", "status", "robots", "trails").
'use strict';

(() => {
  // Colours: cells as in map.png (core/src/map_png.cpp), robots by state.
  const CELL_RGB = [[190, 205, 220], [254, 254, 254], [0, 0, 0]];  // unknown, free, occupied
  const STATE_RGB = {
    'mapping': [21, 101, 192],
    'waiting-map': [117, 117, 117],
    'localising': [239, 108, 0],
    'tracking': [46, 125, 50],
    'lost': [198, 40, 40],
    'stale': [158, 158, 158],
    '-': [117, 117, 117],
  };
  const STALE_S = 5;           // a robot silent this long is drawn grey
  const TRAIL_POINTS = 300;    // per robot, as the server keeps
  const TRAIL_STEP_M = 0.05;
  const HEADER_BYTES = 44;

  const $ = (id) => document.getElementById(id);
  const view = $('view');
  const ctx = view.getContext('2d', { willReadFrequently: true });
  // The map at one pixel per cell, over the bounding box of the tiles held; the view draws it
  // scaled. Pixel column c is cell x = minTx * edge + c, row r is cell y = (maxTy + 1) * edge - 1 - r.
  const cells = document.createElement('canvas');
  const cellsCtx = cells.getContext('2d', { willReadFrequently: true });

  const s = {
    map: null,            // {map_id, epoch, cell_size, tile_edge}
    tiles: new Map(),     // "tx,ty" -> {tx, ty, version, image}
    bounds: null,         // {minTx, minTy, maxTx, maxTy}
    robots: [],
    trails: new Map(),    // id -> [[x, y], ...]
    leaderPath: [],
    status: null,
    bytes: 0,
    frames: 0,
    socket: null,
    connected: false,
    connects: 0,
    connectedAt: 0,       // Date.now() of the last open
    wholeMapAt: null,     // Date.now() when the tiles held first equalled the leader's count
    tileLog: [],          // live tiles: {key, version, stamp_ms, applied_ms, drawn_ms}
    pendingDraw: [],      // tileLog entries waiting for the next paint
    follow: null,
    overlays: true,
    dirty: true,
    // Screen px per cell and the centre in cells; `auto`: refit as the map grows, until the user
    // pans or zooms.
    cam: { scale: 2, cx: 0, cy: 0, auto: true },
  };

  // ---------------------------------------------------------------- the map
  function resetMap(map) {
    s.map = map;
    s.tiles.clear();
    s.bounds = null;
    s.leaderPath = [];
    s.trails.clear();
    s.wholeMapAt = null;
    s.cam.auto = true;
    cells.width = cells.height = 1;
    s.dirty = true;
  }

  function growTo(tx, ty) {
    const b = s.bounds;
    const nb = b ? { minTx: Math.min(b.minTx, tx), minTy: Math.min(b.minTy, ty),
                     maxTx: Math.max(b.maxTx, tx), maxTy: Math.max(b.maxTy, ty) }
                 : { minTx: tx, minTy: ty, maxTx: tx, maxTy: ty };
    if (b && nb.minTx === b.minTx && nb.minTy === b.minTy && nb.maxTx === b.maxTx &&
        nb.maxTy === b.maxTy) return;
    s.bounds = nb;
    const e = s.map.tile_edge;
    cells.width = (nb.maxTx - nb.minTx + 1) * e;
    cells.height = (nb.maxTy - nb.minTy + 1) * e;
    cellsCtx.fillStyle = `rgb(${CELL_RGB[0].join(',')})`;
    cellsCtx.fillRect(0, 0, cells.width, cells.height);
    for (const t of s.tiles.values()) putTile(t);
  }

  function putTile(t) {
    const e = s.map.tile_edge;
    cellsCtx.putImageData(t.image, (t.tx - s.bounds.minTx) * e, (s.bounds.maxTy - t.ty) * e);
  }

  async function onTileFrame(buf, recvMs) {
    if (buf.byteLength < HEADER_BYTES) return;
    const d = new DataView(buf);
    if (d.getUint8(0) !== 0x54 || d.getUint8(1) !== 1) return;
    const compressed = d.getUint8(2) === 1;
    const edge = d.getUint16(4, true);
    const epoch = d.getUint32(8, true);
    const tx = d.getInt32(12, true);
    const ty = d.getInt32(16, true);
    const version = Number(d.getBigUint64(24, true));
    const stampMs = Number(d.getBigUint64(32, true) / 1000000n);
    const size = d.getUint32(40, true);
    if (!s.map || epoch !== s.map.epoch || edge !== s.map.tile_edge) return;
    if (size !== buf.byteLength - HEADER_BYTES || edge === 0) return;
    let classes = new Uint8Array(buf, HEADER_BYTES, size);
    if (compressed) {
      const stream = new Blob([classes]).stream().pipeThrough(new DecompressionStream('deflate'));
      classes = new Uint8Array(await new Response(stream).arrayBuffer());
    }
    if (classes.length !== edge * edge) return;
    if (!s.map || epoch !== s.map.epoch) return;  // a new map arrived while inflating
    const key = `${tx},${ty}`;
    const held = s.tiles.get(key);
    if (held && held.version >= version) return;  // an older copy finished inflating later
    // Row ly of the tile (from its bottom) is image row edge - 1 - ly: north up.
    const image = new ImageData(edge, edge);
    const px = image.data;
    for (let ly = 0; ly < edge; ++ly) {
      const row = (edge - 1 - ly) * edge;
      for (let lx = 0; lx < edge; ++lx) {
        const c = CELL_RGB[classes[ly * edge + lx]] || CELL_RGB[0];
        const o = (row + lx) * 4;
        px[o] = c[0]; px[o + 1] = c[1]; px[o + 2] = c[2]; px[o + 3] = 255;
      }
    }
    const t = { tx, ty, version, image };
    s.tiles.set(key, t);
    growTo(tx, ty);
    putTile(t);
    const now = Date.now();
    if (stampMs >= s.connectedAt) {  // published while connected: a live change
      const entry = { key, version, stamp_ms: stampMs, recv_ms: recvMs, applied_ms: now,
                      drawn_ms: null };
      s.tileLog.push(entry);
      if (s.tileLog.length > 20000) s.tileLog.splice(0, 10000);
      s.pendingDraw.push(entry);
    }
    if (s.cam.auto) fit();
    $('tiles').textContent = s.tiles.size;
    checkWholeMap();
    s.dirty = true;
  }

  function checkWholeMap() {
    if (s.wholeMapAt === null && s.status && s.status.tiles > 0 &&
        s.status.epoch === (s.map && s.map.epoch) && s.tiles.size >= s.status.tiles) {
      s.wholeMapAt = Date.now();
    }
  }

  // ---------------------------------------------------------------- messages
  function onText(text) {
    let m;
    try { m = JSON.parse(text); } catch (e) { return; }
    switch (m.type) {
      case 'map':
        if (!s.map || s.map.epoch !== m.epoch || s.map.map_id !== m.map_id) resetMap(m);
        break;
      case 'status':
        s.status = m;
        checkWholeMap();
        showStatus();
        break;
      case 'robots':
        s.robots = m.robots;
        for (const r of m.robots) extendTrail(r);
        showFleet();
        s.dirty = true;
        break;
      case 'trails':
        for (const [id, pts] of Object.entries(m.trails)) {
          if (!s.trails.has(id) || s.trails.get(id).length < pts.length) s.trails.set(id, pts);
        }
        if (m.leader_path.length > s.leaderPath.length) s.leaderPath = m.leader_path;
        s.dirty = true;
        break;
    }
  }

  function extendTrail(r) {
    let t = s.trails.get(r.id);
    if (!t) s.trails.set(r.id, t = []);
    const last = t[t.length - 1];
    if (!last || Math.hypot(last[0] - r.x, last[1] - r.y) >= TRAIL_STEP_M) {
      t.push([r.x, r.y]);
      if (t.length > TRAIL_POINTS) t.shift();
      if (r.leader && r.status === 'mapping') {
        const p = s.leaderPath[s.leaderPath.length - 1];
        if (!p || p[0] !== r.x || p[1] !== r.y) s.leaderPath.push([r.x, r.y]);
      }
    }
  }

  function connect() {
    const url = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`;
    const ws = new WebSocket(url);
    ws.binaryType = 'arraybuffer';
    s.socket = ws;
    setConn('connecting', false);
    ws.onopen = () => {
      s.connected = true;
      s.connects += 1;
      s.connectedAt = Date.now();
      setConn('connected', true);
    };
    ws.onmessage = (ev) => {
      s.frames += 1;
      if (typeof ev.data === 'string') {
        s.bytes += ev.data.length;
        onText(ev.data);
      } else {
        s.bytes += ev.data.byteLength;
        onTileFrame(ev.data, Date.now());
      }
      $('bytes').textContent = formatBytes(s.bytes);
    };
    ws.onclose = () => {
      s.connected = false;
      setConn('disconnected, retrying', false);
      setTimeout(connect, 1000);
    };
    ws.onerror = () => ws.close();
  }

  // ---------------------------------------------------------------- the panel
  function formatBytes(n) {
    if (n < 1024) return `${n} B`;
    if (n < 1048576) return `${(n / 1024).toFixed(1)} kB`;
    return `${(n / 1048576).toFixed(2)} MB`;
  }

  function setConn(text, ok) {
    const el = $('conn');
    el.textContent = text;
    el.className = ok ? 'ok' : 'bad';
  }

  function showStatus() {
    const st = s.status;
    $('mapid').textContent = st.map_id || '-';
    $('epoch').textContent = st.epoch || '-';
    $('tiles').textContent = s.tiles.size;
    $('leader-tiles').textContent = st.tiles;
    $('scans').textContent = st.scans + (st.complete ? ' (complete)' : '');
    const present = st.leader.present;
    const leader = $('leader');
    leader.textContent = present ? 'present' : (st.leader.lost > 0 ? 'GONE' : 'not seen yet');
    leader.className = present ? 'ok' : 'bad';
    $('banner').hidden = present || st.leader.lost === 0;
    if (!present && st.leader.reason) $('banner').title = st.leader.reason;
    $('dropped').textContent = st.server.dropped;
    $('clients').textContent = st.server.clients;
  }

  function stateOf(r) { return r.age_s > STALE_S ? 'stale' : r.status; }

  function showFleet() {
    const body = $('fleet').tBodies[0];
    const rows = s.robots.filter((r) => !r.leader).concat(s.robots.filter((r) => r.leader));
    const fmt = (v, d) => (v === null || v === undefined ? '-' : Number(v).toFixed(d));
    body.replaceChildren(...rows.map((r) => {
      const tr = document.createElement('tr');
      tr.dataset.id = r.id;
      if (s.follow === r.id) tr.className = 'followed';
      const st = stateOf(r);
      const cellsHtml = [
        r.id, `<span class="st ${st}">${st}</span>`,
        r.localised_s === null || r.localised_s === undefined ? '-' : `${r.localised_s.toFixed(1)} s`,
        fmt(r.err_m, 2), fmt(r.med_m, 2), fmt(r.poses_per_s, 1),
      ];
      for (const [i, v] of cellsHtml.entries()) {
        const td = document.createElement('td');
        if (i === 1) td.innerHTML = v; else td.textContent = v;
        tr.appendChild(td);
      }
      tr.onclick = () => setFollow(r.id);
      return tr;
    }));
  }

  function setFollow(id) {
    s.follow = id;
    $('follow').hidden = id === null;
    $('follow-id').textContent = id || '';
    showFleet();
    s.dirty = true;
  }

  // ---------------------------------------------------------------- drawing
  function resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(view.clientWidth * dpr));
    const h = Math.max(1, Math.round(view.clientHeight * dpr));
    if (view.width !== w || view.height !== h) {
      view.width = w;
      view.height = h;
      s.dirty = true;
    }
  }

  function fit() {
    if (!s.bounds) return;
    const e = s.map.tile_edge;
    const b = s.bounds;
    const wCells = (b.maxTx - b.minTx + 1) * e;
    const hCells = (b.maxTy - b.minTy + 1) * e;
    s.cam.scale = Math.max(0.05, Math.min(view.width / wCells, view.height / hCells) * 0.95);
    s.cam.cx = b.minTx * e + wCells / 2;
    s.cam.cy = b.minTy * e + hCells / 2;
    s.dirty = true;
  }

  // World metres -> screen pixels, and back.
  function toScreen(x, y) {
    const cs = s.map ? s.map.cell_size : 0.05;
    return [view.width / 2 + (x / cs - s.cam.cx) * s.cam.scale,
            view.height / 2 - (y / cs - s.cam.cy) * s.cam.scale];
  }
  function toWorld(sx, sy) {
    const cs = s.map ? s.map.cell_size : 0.05;
    return [((sx - view.width / 2) / s.cam.scale + s.cam.cx) * cs,
            (-(sy - view.height / 2) / s.cam.scale + s.cam.cy) * cs];
  }

  function draw() {
    resize();
    if (s.follow) {
      const r = s.robots.find((q) => q.id === s.follow);
      if (r && s.map) {
        s.cam.cx = r.x / s.map.cell_size;
        s.cam.cy = r.y / s.map.cell_size;
      }
    }
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = `rgb(${CELL_RGB[0].join(',')})`;
    ctx.fillRect(0, 0, view.width, view.height);
    if (!s.map || !s.bounds) return;
    const e = s.map.tile_edge;
    const b = s.bounds;
    ctx.imageSmoothingEnabled = false;
    const x0 = view.width / 2 + (b.minTx * e - s.cam.cx) * s.cam.scale;
    const y0 = view.height / 2 - ((b.maxTy + 1) * e - s.cam.cy) * s.cam.scale;
    ctx.drawImage(cells, x0, y0, cells.width * s.cam.scale, cells.height * s.cam.scale);
    if (!s.overlays) return;
    drawPath(s.leaderPath, 'rgba(21, 101, 192, 0.8)', 1.5);
    for (const [id, pts] of s.trails) {
      const r = s.robots.find((q) => q.id === id);
      if (!r || r.leader) continue;
      drawTrail(pts, STATE_RGB[stateOf(r)] || STATE_RGB['-']);
    }
    for (const r of s.robots) drawRobot(r);
  }

  function drawPath(pts, style, width) {
    if (pts.length < 2) return;
    ctx.strokeStyle = style;
    ctx.lineWidth = width;
    ctx.beginPath();
    pts.forEach(([x, y], i) => {
      const [sx, sy] = toScreen(x, y);
      if (i === 0) ctx.moveTo(sx, sy); else ctx.lineTo(sx, sy);
    });
    ctx.stroke();
  }

  // The trail fades: older segments more transparent.
  function drawTrail(pts, rgb) {
    ctx.lineWidth = 2;
    for (let i = 1; i < pts.length; ++i) {
      const a = 0.05 + 0.75 * (i / pts.length);
      ctx.strokeStyle = `rgba(${rgb.join(',')}, ${a.toFixed(3)})`;
      const [x0, y0] = toScreen(pts[i - 1][0], pts[i - 1][1]);
      const [x1, y1] = toScreen(pts[i][0], pts[i][1]);
      ctx.beginPath();
      ctx.moveTo(x0, y0);
      ctx.lineTo(x1, y1);
      ctx.stroke();
    }
  }

  const MARKER_PX = 8;
  function drawRobot(r) {
    const [sx, sy] = toScreen(r.x, r.y);
    const rgb = STATE_RGB[stateOf(r)] || STATE_RGB['-'];
    ctx.fillStyle = `rgb(${rgb.join(',')})`;
    ctx.strokeStyle = r.id === s.follow ? '#ffd600' : '#fff';
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.arc(sx, sy, MARKER_PX, 0, 2 * Math.PI);
    ctx.fill();
    ctx.stroke();
    // Heading: a line from the centre out of the disc (screen y points down).
    ctx.beginPath();
    ctx.moveTo(sx + Math.cos(r.th) * 3, sy - Math.sin(r.th) * 3);
    ctx.lineTo(sx + Math.cos(r.th) * (MARKER_PX + 8), sy - Math.sin(r.th) * (MARKER_PX + 8));
    ctx.strokeStyle = `rgb(${rgb.join(',')})`;
    ctx.lineWidth = 3;
    ctx.stroke();
    // The name with a white halo, readable over walls and trails.
    ctx.font = 'bold 12px system-ui, sans-serif';
    ctx.lineWidth = 3;
    ctx.strokeStyle = 'rgba(255, 255, 255, 0.9)';
    ctx.strokeText(r.id, sx + MARKER_PX + 3, sy + MARKER_PX + 10);
    ctx.fillStyle = '#111';
    ctx.fillText(r.id, sx + MARKER_PX + 3, sy + MARKER_PX + 10);
  }

  function frame() {
    if (s.dirty) {
      s.dirty = false;
      draw();
      if (s.pendingDraw.length) {
        const now = Date.now();
        for (const e of s.pendingDraw) e.drawn_ms = now;
        s.pendingDraw = [];
      }
    }
    requestAnimationFrame(frame);
  }

  // ---------------------------------------------------------------- pan, zoom, follow
  let drag = null;
  view.addEventListener('mousedown', (ev) => {
    drag = { x: ev.offsetX, y: ev.offsetY, moved: false };
    view.style.cursor = 'grabbing';
  });
  window.addEventListener('mouseup', (ev) => {
    view.style.cursor = 'grab';
    if (drag && !drag.moved && ev.target === view) pick(ev.offsetX, ev.offsetY);
    drag = null;
  });
  view.addEventListener('mousemove', (ev) => {
    if (!drag) return;
    const dpr = window.devicePixelRatio || 1;
    const dx = ev.offsetX - drag.x, dy = ev.offsetY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
    if (!drag.moved) return;
    if (s.follow) setFollow(null);
    s.cam.auto = false;
    s.cam.cx -= (dx * dpr) / s.cam.scale;
    s.cam.cy += (dy * dpr) / s.cam.scale;
    drag.x = ev.offsetX;
    drag.y = ev.offsetY;
    s.dirty = true;
  });
  view.addEventListener('wheel', (ev) => {
    ev.preventDefault();
    const dpr = window.devicePixelRatio || 1;
    const [wx, wy] = toWorld(ev.offsetX * dpr, ev.offsetY * dpr);
    s.cam.auto = false;
    const k = Math.exp(-ev.deltaY * 0.0015);
    s.cam.scale = Math.min(64, Math.max(0.05, s.cam.scale * k));
    // Keep the point under the mouse where it was.
    const [sx, sy] = toScreen(wx, wy);
    s.cam.cx += (sx - ev.offsetX * dpr) / s.cam.scale;
    s.cam.cy -= (sy - ev.offsetY * dpr) / s.cam.scale;
    s.dirty = true;
  }, { passive: false });
  view.addEventListener('dblclick', () => { setFollow(null); s.cam.auto = true; fit(); });
  $('unfollow').onclick = () => setFollow(null);

  function pick(ox, oy) {
    const dpr = window.devicePixelRatio || 1;
    let best = null, bestD = 14 * dpr;
    for (const r of s.robots) {
      const [sx, sy] = toScreen(r.x, r.y);
      const d = Math.hypot(sx - ox * dpr, sy - oy * dpr);
      if (d < bestD) { best = r; bestD = d; }
    }
    if (best) setFollow(best.id);
  }

  window.addEventListener('resize', () => { s.dirty = true; });

  // ---------------------------------------------------------------- test and bench hooks
  // Read-only looks at what the page holds and drew (tests/view/browser_test.mjs uses them).
  window.esfleetView = {
    state: () => ({
      connected: s.connected, connects: s.connects, map: s.map, tiles: s.tiles.size,
      bounds: s.bounds, bytes: s.bytes, frames: s.frames, status: s.status,
      connectedAt: s.connectedAt, wholeMapAt: s.wholeMapAt, follow: s.follow,
      banner: !$('banner').hidden, robots: s.robots,
    }),
    tileLog: () => s.tileLog.slice(),
    // Where robot `id` was drawn (canvas pixels) and in which colour.
    marker: (id) => {
      const r = s.robots.find((q) => q.id === id);
      if (!r || !s.map) return null;
      const [sx, sy] = toScreen(r.x, r.y);
      return { x: r.x, y: r.y, sx, sy, status: stateOf(r), rgb: STATE_RGB[stateOf(r)],
               world: toWorld(sx, sy) };
    },
    stateColours: () => STATE_RGB,
    // Draws the map at exactly one canvas pixel per cell, its top-left tile corner at canvas
    // (0, 0), with or without the robots; returns what cell canvas pixel (0, 0) shows.
    oneToOne: (overlays) => {
      if (!s.bounds) return null;
      const e = s.map.tile_edge;
      setFollow(null);
      s.cam.auto = false;
      s.overlays = overlays;
      resize();
      s.cam.scale = 1;
      s.cam.cx = s.bounds.minTx * e + view.width / 2;
      s.cam.cy = (s.bounds.maxTy + 1) * e - view.height / 2;
      draw();
      return { cellX0: s.bounds.minTx * e, cellYTop: (s.bounds.maxTy + 1) * e - 1,
               width: Math.min(view.width, cells.width), height: Math.min(view.height, cells.height) };
    },
    setOverlays: (on) => { s.overlays = on; s.dirty = true; },
    fit: () => fit(),
  };

  resize();
  connect();
  requestAnimationFrame(frame);
})();
