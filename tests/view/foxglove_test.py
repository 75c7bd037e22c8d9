#!/usr/bin/env python3
"""esfleet-view speaks the Foxglove WebSocket protocol (Python 3 stdlib only).

usage: foxglove_test.py BIN_DIR PROJECT_DIR DOMAIN PORT

A leader maps 150 CSAIL scans; a client connects to esfleet-view's /ws asking for the
subprotocol foxglove.websocket.v1 and must get it, then serverInfo and an advertise of /map
(nav_msgs/msg/OccupancyGrid, cdr, ros2msg schema) and /robots (geometry_msgs/msg/PoseArray);
after subscribing to both, MessageData frames: a ROS 2 CDR OccupancyGrid (resolution 0.05,
width x height cells, values -1/0/100, as many occupied and free cells as the view's map.pgm
download) and a PoseArray with the leader's pose. A client asking for no
subprotocol still gets the page's protocol.
"""
import base64
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request

bin_dir, project, domain, port = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
profile = f"{project}/deploy/fastdds/localhost-udp.xml"
work = tempfile.mkdtemp(prefix="esfleet-foxglove.")
dds = ["--domain", domain, "--profile", profile]
procs = []


def start(args, name):
    p = subprocess.Popen(args, stdout=open(f"{work}/{name}.log", "w"), stderr=subprocess.STDOUT)
    procs.append(p)
    return p


def get(path):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as r:
        return r.read()


def ws_connect(protocol):
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    extra = f"Sec-WebSocket-Protocol: {protocol}\r\n" if protocol else ""
    s.sendall((f"GET /ws HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
               f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n{extra}\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += s.recv(1)
    return s, head.decode()


def recv_exact(s, n):
    out = b""
    while len(out) < n:
        chunk = s.recv(n - len(out))
        if not chunk:
            raise EOFError("closed")
        out += chunk
    return out


def read_message(s):
    """One message: its opcode and payload, fragments (continuation frames) joined."""
    opcode, payload = None, b""
    while True:
        b0, b1 = recv_exact(s, 2)
        n = b1 & 0x7F
        if n == 126:
            n = struct.unpack("!H", recv_exact(s, 2))[0]
        elif n == 127:
            n = struct.unpack("!Q", recv_exact(s, 8))[0]
        payload += recv_exact(s, n)
        if opcode is None:
            opcode = b0 & 0x0F
        if b0 & 0x80:
            return opcode, payload


def send_text(s, text):
    data = text.encode()
    key = os.urandom(4)
    hdr = struct.pack("!BB", 0x81, 0x80 | len(data)) if len(data) < 126 else \
        struct.pack("!BBH", 0x81, 0x80 | 126, len(data))
    s.sendall(hdr + key + bytes(c ^ key[i % 4] for i, c in enumerate(data)))


def occupancy_grid(cdr):
    assert cdr[:4] == b"\x00\x01\x00\x00", f"encapsulation {cdr[:4]!r} is not CDR little-endian"
    b = cdr[4:]
    pos = 0

    def take(fmt, align):
        nonlocal pos
        pos = (pos + align - 1) // align * align
        v = struct.unpack_from("<" + fmt, b, pos)
        pos += struct.calcsize("<" + fmt)
        return v
    take("iI", 4)                      # header.stamp
    (n,) = take("I", 4)                # header.frame_id
    frame = b[pos:pos + n - 1].decode()
    pos += n
    take("iI", 4)                      # info.map_load_time
    (res,) = take("f", 4)
    width, height = take("II", 4)
    origin = take("ddd", 8) + take("dddd", 8)
    (count,) = take("I", 4)
    data = struct.unpack_from(f"<{count}b", b, pos)
    return frame, res, width, height, origin, data


failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


try:
    view = start([f"{bin_dir}/esfleet-view", *dds, "--port", str(port), "--bind", "127.0.0.1"],
                 "view")
    start([f"{bin_dir}/esfleet-leader", "--log", f"{project}/data/mit-csail/mit-csail.clf.gz",
           "--odometry", "on", "--max-scans", "150", *dds, "--out", f"{work}/leader",
           "--linger", "60"], "leader")
    end = time.time() + 60
    while time.time() < end:
        try:
            if json.loads(get("/status.json")).get("complete"):
                break
        except OSError:
            pass
        time.sleep(0.2)
    status = json.loads(get("/status.json"))
    check(status.get("complete", False), f"the view holds the complete map ({status.get('tiles')} tiles)")

    s, head = ws_connect("foxglove.websocket.v1")
    check("101" in head.split("\r\n")[0] and
          "sec-websocket-protocol: foxglove.websocket.v1" in head.lower(),
          "subprotocol foxglove.websocket.v1 accepted")
    op, info = read_message(s)
    info = json.loads(info)
    check(op == 1 and info.get("op") == "serverInfo", "serverInfo first")
    op, adv = read_message(s)
    adv = json.loads(adv)
    channels = {c["topic"]: c for c in adv.get("channels", [])} if adv.get("op") == "advertise" else {}
    ch = channels.get("/map", {})
    check(ch.get("encoding") == "cdr" and ch.get("schemaName") == "nav_msgs/msg/OccupancyGrid" and
          ch.get("schemaEncoding") == "ros2msg" and "MSG: nav_msgs/MapMetaData" in ch.get("schema", ""),
          "advertise: /map as nav_msgs/msg/OccupancyGrid, cdr, ros2msg schema")
    rch = channels.get("/robots", {})
    check(rch.get("encoding") == "cdr" and rch.get("schemaName") == "geometry_msgs/msg/PoseArray" and
          "MSG: geometry_msgs/Pose" in rch.get("schema", ""),
          "advertise: /robots as geometry_msgs/msg/PoseArray")
    send_text(s, json.dumps({"op": "subscribe", "subscriptions": [
        {"id": 7, "channelId": ch["id"]}, {"id": 8, "channelId": rch["id"]}]}))
    s.settimeout(10)
    got = {}
    while len(got) < 2:
        op, msg = read_message(s)
        if op == 2 and msg[0] == 1:
            got[struct.unpack_from("<I", msg, 1)[0]] = msg[13:]
    check(set(got) == {7, 8}, "MessageData (opcode 1) for subscriptions 7 (/map) and 8 (/robots)")
    pa = got[8]
    assert pa[:4] == b"\x00\x01\x00\x00"
    (n,) = struct.unpack_from("<I", pa, 12)
    frame_id = pa[16:16 + n - 1].decode()
    pos = 16 + n
    pos = (pos - 4 + 3) // 4 * 4 + 4
    (count,) = struct.unpack_from("<I", pa, pos)
    pos = (pos + 4 - 4 + 7) // 8 * 8 + 4
    poses = [struct.unpack_from("<7d", pa, pos + 56 * i) for i in range(count)]
    check(frame_id == "map" and count >= 1 and len(pa) == pos + 56 * count and
          all(abs(q[3] ** 2 + q[4] ** 2 + q[5] ** 2 + q[6] ** 2 - 1) < 1e-9 for q in poses),
          f"PoseArray in frame map: {count} robot(s) (the leader), unit quaternions")
    frame, res, width, height, origin, data = occupancy_grid(got[7])
    check(frame == "map" and abs(res - 0.05) < 1e-6 and width * height == len(data) and
          set(data) <= {-1, 0, 100},
          f"OccupancyGrid: frame {frame}, resolution {res:.3f}, {width}x{height}, values -1/0/100")
    pgm = get("/download/map.pgm")
    parts = pgm.split(b"\n", 3)  # P5, size, maxval, pixels (the writer puts no comments)
    pixels = parts[3]
    occ_pgm, free_pgm = pixels.count(b"\x00"), pixels.count(b"\xfe")
    occ, free = data.count(100), data.count(0)
    check(occ == occ_pgm and free == free_pgm and occ > 100,
          f"the grid has the map.pgm's cells: {occ} occupied ({occ_pgm}), {free} free ({free_pgm})")
    s.close()

    s, head = ws_connect(None)
    op, first = read_message(s)
    check(json.loads(first).get("type") == "map" and "sec-websocket-protocol" not in head.lower(),
          "no subprotocol: the page's protocol (a map message first)")
    s.close()
    view.send_signal(2)
    check(view.wait(timeout=15) == 130, "esfleet-view exited 130 on SIGINT")
finally:
    for p in procs:
        if p.poll() is None:
            p.send_signal(2)
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
if failures:
    for name in ("view", "leader"):
        print(f"--- {name}.log\n" + open(f"{work}/{name}.log").read()[-2000:])
shutil.rmtree(work, ignore_errors=True)
if failures:
    sys.exit(1)
print("Foxglove client served")
