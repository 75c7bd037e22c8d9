#!/usr/bin/env python3
"""Hostile HTTP and WebSocket input against a running esfleet-view (Python 3 stdlib only).

usage: hostile_test.py BIN_DIR PROFILE DOMAIN PORT

Starts esfleet-view, then: path traversal in many spellings, a 100 kB header, a body, a bad
method, garbage bytes, an oversized WebSocket frame, malformed WebSocket frames (unmasked,
reserved bits, a reserved opcode, a fragmented control frame, a bad close code, invalid UTF-8
text), a WebSocket on another path, 2000 connections at once and requests that never end. Each
must be refused (a 4xx status, the WebSocket close code due, or the connection closed);
afterwards the page is still served and esfleet-view exits 130 on SIGINT (it never crashed).
"""
import base64
import json
import os
import resource
import socket
import struct
import subprocess
import sys
import time

bin_dir, profile, domain, port = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
HOST = "127.0.0.1"
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)


def connect(timeout=5.0):
    s = socket.create_connection((HOST, port), timeout=timeout)
    s.settimeout(timeout)
    return s


def read_all(s, limit=1 << 20):
    out = b""
    try:
        while len(out) < limit:
            chunk = s.recv(65536)
            if not chunk:
                break
            out += chunk
    except (ConnectionResetError, socket.timeout, BrokenPipeError):
        pass
    return out


def exchange(raw):
    s = connect()
    try:
        s.sendall(raw)
    except (BrokenPipeError, ConnectionResetError):
        pass  # closed while we were still sending: a refusal too
    out = read_all(s)
    s.close()
    return out


def status(resp):
    if not resp.startswith(b"HTTP/1.1 "):
        return 0
    return int(resp[9:12])


def get(path):
    return exchange(f"GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".encode())


def ws_open(path="/ws"):
    s = connect()
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall((f"GET {path} HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
               f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = s.recv(4096)
        if not chunk:
            break
        head += chunk
    return s, head


def frame(opcode, payload, fin=True, mask=True, rsv=0, declared=None):
    b0 = (0x80 if fin else 0) | (rsv << 4) | opcode
    n = len(payload) if declared is None else declared
    if n < 126:
        hdr = struct.pack("!BB", b0, (0x80 if mask else 0) | n)
    elif n < 65536:
        hdr = struct.pack("!BBH", b0, (0x80 if mask else 0) | 126, n)
    else:
        hdr = struct.pack("!BBQ", b0, (0x80 if mask else 0) | 127, n)
    if not mask:
        return hdr + payload
    key = os.urandom(4)
    return hdr + key + bytes(c ^ key[i % 4] for i, c in enumerate(payload))


def close_code(data):
    """The close code of the first close frame the server sent (after any data frames), None if
    it closed the TCP connection without one."""
    i = 0
    while i + 2 <= len(data):
        op = data[i] & 0x0F
        n = data[i + 1] & 0x7F
        j = i + 2
        if n == 126:
            n = struct.unpack("!H", data[j:j + 2])[0]
            j += 2
        elif n == 127:
            n = struct.unpack("!Q", data[j:j + 8])[0]
            j += 8
        if op == 0x8:
            return struct.unpack("!H", data[j:j + 2])[0] if n >= 2 else 1005
        i = j + n
    return None


def ws_refused(payload_frames, what, codes):
    s, head = ws_open()
    check(head.startswith(b"HTTP/1.1 101"), f"{what}: handshake accepted first")
    try:
        for f in payload_frames:
            s.sendall(f)
    except (BrokenPipeError, ConnectionResetError):
        pass
    data = read_all(s, limit=50 << 20)
    s.close()
    code = close_code(data)
    check(code in codes, f"{what}: closed by the server (close code {code}, expected {codes})")


def page_ok(what):
    r = get("/")
    check(status(r) == 200 and b"<canvas id=\"view\">" in r, f"page still served {what}")


def stats():
    r = get("/stats.json")
    body = r.split(b"\r\n\r\n", 1)[1] if b"\r\n\r\n" in r else b"{}"
    return json.loads(body or b"{}")


view = subprocess.Popen([f"{bin_dir}/esfleet-view", "--domain", str(domain), "--profile", profile,
                         "--port", str(port), "--bind", HOST],
                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
try:
    for _ in range(100):
        try:
            connect(0.2).close()
            break
        except OSError:
            time.sleep(0.1)
    page_ok("at start")
    # Slow requests (a header that never ends) are closed after the request timeout (10 s).
    slow = [connect(30.0) for _ in range(3)]
    for s in slow:
        s.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n")
    slow_since = time.monotonic()

    # --- paths: only the fixed set, nothing from the file system ---
    for path in ["/../../etc/passwd", "/..%2f..%2fetc%2fpasswd", "/%2e%2e/%2e%2e/etc/passwd",
                 "//etc/passwd", "/etc/passwd", "/view.js/../../../etc/passwd",
                 "/download/../../../etc/passwd", "/download/..%2f..%2fetc%2fpasswd",
                 "/download/map.yaml/../../etc/passwd", "/web/index.html", "/index.html",
                 "/.git/config", "/CMakeLists.txt", "/%00", "/" + "a" * 4000,
                 "http://x/../../etc/passwd"]:
        r = get(path)
        check(status(r) == 404 and b"root:" not in r, f"GET {path[:60]} -> 404")
    r = exchange(b"GET /../../etc/passwd HTTP/1.0\r\n\r\n")
    check(status(r) == 404 and b"root:" not in r, "HTTP/1.0 traversal -> 404")

    # --- sizes and methods ---
    r = exchange(b"GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + b"a" * 100_000 + b"\r\n\r\n")
    check(status(r) in (431, 0), f"100 kB header refused (status {status(r)})")
    r = exchange(b"GET / HTTP/1.1\r\nHost: x\r\n" + b"X-A: b\r\n" * 5000 + b"\r\n")
    check(status(r) in (431, 0), f"5000 header lines refused (status {status(r)})")
    r = exchange(b"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000\r\n\r\n" + b"x" * 1000)
    check(status(r) == 413, f"a body refused (status {status(r)})")
    r = exchange(b"GET / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
                 b"100000\r\n" + b"x" * 1000)
    check(status(r) in (413, 400), f"a chunked body refused (status {status(r)})")
    for method in [b"POST", b"PUT", b"DELETE", b"OPTIONS", b"TRACE"]:
        r = exchange(method + b" / HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n")
        check(status(r) == 405, f"{method.decode()} -> 405")
    for garbage in [os.urandom(5000), b"\x16\x03\x01\x00\xa5\x01\x00\x00\xa1\x03\x03" + b"\0" * 200,
                    b"GET / HTTP/9.9\r\n\r\n", b"GET\r\n\r\n", b"\r\n" * 10000,
                    b"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: -1\r\n\r\n",
                    b"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999999999999\r\n\r\n"]:
        r = exchange(garbage)
        check(status(r) in (400, 413, 431, 0), f"garbage {garbage[:16]!r} refused ({status(r)})")
    page_ok("after bad HTTP")

    # --- WebSocket ---
    s, head = ws_open("/nope")
    check(head.startswith(b"HTTP/1.1 404"), "WebSocket on another path -> 404")
    s.close()
    ws_refused([frame(0x2, b"x" * 200_000)], "oversized frame (200 kB)", {1009})
    ws_refused([frame(0x2, b"x" * 1000, declared=1 << 40)], "frame declaring 1 TB", {1009, 1002})
    ws_refused([frame(0x1, b"hello", mask=False)], "unmasked client frame", {1002})
    ws_refused([frame(0x1, b"hello", rsv=4)], "reserved bit set", {1002})
    ws_refused([frame(0x3, b"hello")], "reserved opcode 3", {1002})
    ws_refused([frame(0x9, b"p" * 10, fin=False)], "fragmented ping", {1002})
    ws_refused([frame(0x9, b"p" * 200)], "ping of 200 bytes", {1002})
    ws_refused([frame(0x8, struct.pack("!H", 999))], "close code 999", {1002})
    ws_refused([frame(0x1, b"\xff\xfe\xfd")], "invalid UTF-8 text", {1007})
    ws_refused([frame(0x0, b"continuation without a start")], "stray continuation", {1002})
    ws_refused([frame(0x2, b"x" * 3000, fin=False), frame(0x0, b"x" * 3000)],
               "fragments adding up past the limit", {1009})
    page_ok("after bad WebSocket frames")

    # --- 2000 connections at once ---
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(max(soft, 4096), hard), hard))
    socks, refused_connect = [], 0
    for _ in range(2000):
        try:
            socks.append(connect(10.0))
        except OSError:
            refused_connect += 1
    time.sleep(1.0)
    closed = 0
    for s in socks:
        s.setblocking(False)
        try:
            if s.recv(1) == b"":
                closed += 1
        except BlockingIOError:
            pass
        except (ConnectionResetError, OSError):
            closed += 1
    open_now = len(socks) - closed
    check(open_now <= 256, f"2000 connections: {open_now} held open (limit 256), {closed} closed "
          f"by the server, {refused_connect} not accepted by the kernel")
    check(closed + refused_connect >= 2000 - 256, "the connections beyond the limit refused")
    for s in socks:
        s.close()
    time.sleep(0.5)
    page_ok("after 2000 connections")
    st = stats()
    check(st.get("server", {}).get("refused", 0) >= 1000,
          f"server counted {st.get('server', {}).get('refused')} refused connections")
    time.sleep(max(0.0, 11.5 - (time.monotonic() - slow_since)))
    for s in slow:
        s.settimeout(1.0)
        try:
            gone = s.recv(1) == b""
        except (ConnectionResetError, socket.timeout, OSError) as e:
            gone = not isinstance(e, socket.timeout)
        check(gone, "a request still incomplete after 10 s: connection closed")
        s.close()
    check(view.poll() is None, "esfleet-view still running")
finally:
    if view.poll() is None:
        view.send_signal(2)
    try:
        rc = view.wait(timeout=15)
    except subprocess.TimeoutExpired:
        view.kill()
        rc = view.wait()
    out = view.stdout.read().decode(errors="replace")
check(rc == 130, f"esfleet-view exited {rc} on SIGINT (130 expected: it never crashed)")
if failures:
    print(out[-3000:])
    print(f"{len(failures)} checks failed", file=sys.stderr)
    sys.exit(1)
print("all hostile inputs refused")
