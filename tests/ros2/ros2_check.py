#!/usr/bin/env python3
"""Checks for the ROS 2 interop tests (tests/ros2/*.sh): compares what the Cyclone DDS peer
(esfleet-ros2-peer) received with what esfleet saved. Standard library only.

  ros2_check.py grid-equals-pgm PREFIX MAP_YAML   the grid PREFIX.json/.bin equals, cell for
      cell, the map_server reading of MAP_YAML (trinary: occupied 100, free 0, else -1); grid
      cells outside the image must be unknown
  ros2_check.py grids-equal PREFIX_A PREFIX_B     two grids are identical (geometry and cells)
  ros2_check.py trajectories-equal A B [TOL]      two trajectory files (stamp x y theta per line)
      hold the same poses, to TOL (default 0: bit for bit as printed)
  ros2_check.py poses-near POSES_JSONL TRAJ TOL   every pose the peer received lies within TOL m
      of the trajectory pose with the same stamp (1 ms)
  ros2_check.py tf-consistent POSES_JSONL ROBOT_FRAMES...  see tf_consistent()
"""
import json
import math
import sys


def fail(msg):
    print("FAIL: " + msg, file=sys.stderr)
    sys.exit(1)


def load_grid(prefix):
    with open(prefix + ".json") as f:
        meta = json.load(f)
    with open(prefix + ".bin", "rb") as f:
        data = f.read()
    if len(data) != meta["width"] * meta["height"]:
        fail(f"{prefix}.bin holds {len(data)} bytes, not {meta['width']}x{meta['height']}")
    cells = [b - 256 if b > 127 else b for b in data]
    return meta, cells


def load_yaml(path):
    meta = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                meta[k.strip()] = v.strip()
    origin = [float(x) for x in meta["origin"].strip("[]").split(",")]
    return meta["image"], float(meta["resolution"]), origin, float(meta["occupied_thresh"]), \
        float(meta["free_thresh"])


def load_pgm(path):
    with open(path, "rb") as f:
        raw = f.read()
    tokens, pos = [], 0
    while len(tokens) < 4:
        while raw[pos:pos + 1].isspace():
            pos += 1
        if raw[pos:pos + 1] == b"#":
            pos = raw.index(b"\n", pos) + 1
            continue
        end = pos
        while not raw[end:end + 1].isspace():
            end += 1
        tokens.append(raw[pos:end])
        pos = end
    if tokens[0] != b"P5" or tokens[3] != b"255":
        fail(f"{path}: not a binary 8-bit PGM")
    w, h = int(tokens[1]), int(tokens[2])
    pixels = raw[pos + 1:pos + 1 + w * h]
    if len(pixels) != w * h:
        fail(f"{path}: truncated")
    return w, h, pixels


def grid_equals_pgm(prefix, yaml_path):
    import os
    image, res, origin, occ_th, free_th = load_yaml(yaml_path)
    w, h, pixels = load_pgm(os.path.join(os.path.dirname(yaml_path), image))
    meta, cells = load_grid(prefix)
    if abs(meta["resolution"] - res) > 1e-6:
        fail(f"resolution {meta['resolution']} != {res}")
    dx = round((origin[0] - meta["origin_x"]) / res)
    dy = round((origin[1] - meta["origin_y"]) / res)
    if abs(origin[0] - meta["origin_x"] - dx * res) > 1e-4 or \
            abs(origin[1] - meta["origin_y"] - dy * res) > 1e-4:
        fail("the image origin is not on the grid's cells")
    expected = [-1] * (meta["width"] * meta["height"])
    for row in range(h):
        y = dy + (h - 1 - row)
        for col in range(w):
            x = dx + col
            if not (0 <= x < meta["width"] and 0 <= y < meta["height"]):
                fail(f"image pixel ({col}, {row}) lies outside the grid")
            occ = 1.0 - pixels[row * w + col] / 255.0
            v = 100 if occ > occ_th else 0 if occ < free_th else -1
            expected[y * meta["width"] + x] = v
    diff = sum(1 for a, b in zip(cells, expected) if a != b)
    known = sum(1 for v in expected if v != -1)
    print(f"grid {meta['width']}x{meta['height']}: {known} known cells in the saved map, "
          f"{diff} cells differ")
    if diff:
        fail(f"{diff} cells differ from {yaml_path}")


def grids_equal(a, b):
    ma, ca = load_grid(a)
    mb, cb = load_grid(b)
    for k in ("width", "height", "resolution", "origin_x", "origin_y"):
        if ma[k] != mb[k]:
            fail(f"{k}: {ma[k]} != {mb[k]}")
    diff = sum(1 for x, y in zip(ca, cb) if x != y)
    print(f"{a} vs {b}: {diff} cells differ of {len(ca)}")
    if diff:
        fail(f"{diff} cells differ")


def load_traj(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                rows.append([float(v) for v in line.split()[:4]])
    return rows


def trajectories_equal(a, b, tol):
    ta, tb = load_traj(a), load_traj(b)
    if len(ta) != len(tb):
        fail(f"{a} has {len(ta)} poses, {b} {len(tb)}")
    worst = 0.0
    for ra, rb in zip(ta, tb):
        if abs(ra[0] - rb[0]) > 1e-6:
            fail(f"stamps differ: {ra[0]} vs {rb[0]}")
        worst = max(worst, math.hypot(ra[1] - rb[1], ra[2] - rb[2]),
                    abs(math.remainder(ra[3] - rb[3], 2 * math.pi)))
    print(f"{len(ta)} poses, largest difference {worst:.3g}")
    if worst > tol:
        fail(f"trajectories differ by {worst} > {tol}")


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def nearest(traj, stamp):
    best = min(traj, key=lambda r: abs(r[0] - stamp))
    return best if abs(best[0] - stamp) < 1e-3 else None


def poses_near(jsonl, traj_path, tol):
    traj = load_traj(traj_path)
    poses = [r for r in load_jsonl(jsonl) if r["kind"] == "pose"]
    if not poses:
        fail("no pose received")
    for p in poses:
        t = nearest(traj, p["stamp"])
        if t is None:
            fail(f"no trajectory pose at stamp {p['stamp']}")
        d = math.hypot(p["x"] - t[1], p["y"] - t[2])
        if d > tol or abs(math.remainder(p["yaw"] - t[3], 2 * math.pi)) > 0.1:
            fail(f"pose at {p['stamp']} is ({p['x']:.3f}, {p['y']:.3f}, {p['yaw']:.3f}), "
                 f"the trajectory's ({t[1]:.3f}, {t[2]:.3f}, {t[3]:.3f})")
        cov = p["cov"]
        if not (cov[0] > 0 and cov[7] > 0 and cov[35] > 0):
            fail(f"covariance {cov[0]}, {cov[7]}, {cov[35]} is not positive")
    print(f"{len(poses)} poses within {tol} m of the trajectory")


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def tf_consistent(jsonl, map_frame, odom_frame, base_frame):
    """Every pose equals map->odom (ours) composed with odom->base (the robot's) at its stamp."""
    rows = load_jsonl(jsonl)
    tfs = {}
    for r in rows:
        if r["kind"] == "tf":
            tfs[(r["parent"], r["child"], round(r["stamp"], 6))] = (r["x"], r["y"], r["yaw"])
    checked = 0
    for p in (r for r in rows if r["kind"] == "pose"):
        key = round(p["stamp"], 6)
        m2o = tfs.get((map_frame, odom_frame, key))
        o2b = tfs.get((odom_frame, base_frame, key))
        if m2o is None or o2b is None:
            continue
        b = compose(m2o, o2b)
        if math.hypot(b[0] - p["x"], b[1] - p["y"]) > 1e-6 or \
                abs(math.remainder(b[2] - p["yaw"], 2 * math.pi)) > 1e-6:
            fail(f"at {p['stamp']}: map->odom->base gives {b}, the pose is "
                 f"({p['x']}, {p['y']}, {p['yaw']})")
        checked += 1
    print(f"{checked} poses agree with map -> {odom_frame} -> {base_frame}")
    if checked == 0:
        fail("no pose had both transforms at its stamp")


def main():
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "grid-equals-pgm":
        grid_equals_pgm(*args)
    elif cmd == "grids-equal":
        grids_equal(*args)
    elif cmd == "trajectories-equal":
        trajectories_equal(args[0], args[1], float(args[2]) if len(args) > 2 else 0.0)
    elif cmd == "poses-near":
        poses_near(args[0], args[1], float(args[2]))
    elif cmd == "tf-consistent":
        tf_consistent(*args)
    else:
        fail("unknown command " + cmd)


if __name__ == "__main__":
    main()
