#!/usr/bin/env python3
"""Replays declaration rules on full localisation traces (docs/localisation.md).

Input: traces written by
    esfleet-bench localise ... --trace FILE --trace-all
(every start, every scan, every hypothesis of the pool). For each start the replay finds the
first scan at which a rule would declare a pose and whether that hypothesis was within
0.3 m / 5 deg of the reference. It cannot rerun the localiser's local check and final global
search, so it declares more than the real runs do; compare rules against the default rule
replayed, not against the benchmark's figures.

Usage: bench/replay-declaration-rules.py TRACE [TRACE ...]
Prints one row per rule: right / wrong / undeclared per trace and over all.
"""

import re
import sys
from collections import defaultdict

LINE = re.compile(
    r"scan (\d+) (\w+)(?: G)? hyps \d+ lead err ([\d.]+) m ([\d.]+) deg .* rival ([\d.]+)")
WINDOW = 4  # LocaliserConfig::confirm_scans: the scores are means over this many scans
AMBIGUITY = 0.75  # LocaliserConfig::max_ambiguity (default)
TOL_XY, TOL_DEG = 0.3, 5.0


def load(path):
    """Starts of a trace: each a list of scans, each with the pool's hypotheses."""
    starts = []
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if line.startswith("case "):
                starts.append([])
            elif line.startswith("  scan"):
                m = LINE.search(line)
                if not m or not starts:
                    sys.exit(f"{path}:{n}: not a localisation trace line")
                err, err_deg = float(m.group(3)), float(m.group(4))
                starts[-1].append({"state": m.group(2),
                                   "right": err <= TOL_XY and err_deg <= TOL_DEG, "pool": []})
            elif line.startswith("    pool"):
                if not starts or not starts[-1]:
                    sys.exit(f"{path}:{n}: pool line before any scan")
                for tok in line.split()[1:]:
                    try:
                        hid, e, d, hit, known, pts = tok.split(":")
                        starts[-1][-1]["pool"].append(
                            (int(hid), float(e) <= TOL_XY and float(d) <= TOL_DEG,
                             int(hit), int(known), int(pts)))
                    except ValueError:
                        sys.exit(f"{path}:{n}: bad pool entry {tok!r} (run with --trace-all)")
    if not any(scan["pool"] for scans in starts for scan in scans):
        sys.exit(f"{path}: no pool lines: write the trace with --trace-all")
    return starts


def stats(history):
    """Means over the last WINDOW scans, and the good streak (agreement >= 0.8, known >= 0.5)."""
    last = history[-WINDOW:]
    mean = lambda f: sum(f(*h) for h in last) / len(last)
    streak = 0
    for hit, known, pts in reversed(history):
        if known > 0 and hit / known >= 0.8 and known / pts >= 0.5:
            streak += 1
        else:
            break
    return {"evidence": mean(lambda h, k, p: h / p),
            "contradiction": mean(lambda h, k, p: (k - h) / p),
            "agreement": mean(lambda h, k, p: h / max(k, 1)),
            "known": mean(lambda h, k, p: k / p),
            "streak": streak, "age": len(history)}


def default_rule(pool):
    """The leader by mean evidence, good for 4 scans, every rival below AMBIGUITY of it (the
    replay approximates 'moved' by 4 scans of age)."""
    if not pool:
        return None
    lead = max(pool, key=lambda i: pool[i]["evidence"])
    s = pool[lead]
    if s["streak"] < WINDOW or s["age"] < WINDOW:
        return None
    if all(pool[j]["evidence"] <= AMBIGUITY * s["evidence"] for j in pool if j != lead):
        return lead
    return None


def confident(min_evidence, max_rival):
    def rule(pool):
        if not pool:
            return None
        lead = max(pool, key=lambda i: pool[i]["evidence"])
        s = pool[lead]
        if s["streak"] < WINDOW or s["age"] < WINDOW or s["evidence"] < min_evidence:
            return None
        ok = all(pool[j]["evidence"] <= max_rival * s["evidence"] for j in pool if j != lead)
        return lead if ok else None
    return rule


def contradictions(factor, margin, min_agreement, min_known, min_age=6):
    """Any hypothesis whose every rival is either clearly worse by evidence or has at least
    factor x its share of end points on known free cells + margin."""
    def rule(pool):
        for i, s in pool.items():
            if (s["streak"] < WINDOW or s["age"] < min_age or s["agreement"] < min_agreement
                    or s["known"] < min_known):
                continue
            if all(r["evidence"] <= AMBIGUITY * s["evidence"]
                   or r["contradiction"] >= factor * s["contradiction"] + margin
                   for j, r in pool.items() if j != i):
                return i
        return None
    return rule


def either(a, b):
    return lambda pool: a(pool) if a(pool) is not None else b(pool)


def replay(starts, rule, budget=300):
    right = wrong = undeclared = 0
    for scans in starts:
        history = defaultdict(list)
        outcome = None
        for scan in scans[:budget]:
            if scan["state"] == "tracking":  # the real run declared here
                outcome = scan["right"]
                break
            now = {}
            for hid, near, hit, known, pts in scan["pool"]:
                history[hid].append((hit, known, pts))
                now[hid] = near
            for hid in list(history):
                if hid not in now:
                    del history[hid]
            pool = {hid: stats(history[hid]) for hid in now}
            chosen = rule(pool)
            if chosen is not None:
                outcome = now[chosen]
                break
        if outcome is None:
            undeclared += 1
        elif outcome:
            right += 1
        else:
            wrong += 1
    return right, wrong, undeclared


RULES = {
    "default (replayed)": default_rule,
    "+ evidence >= 0.9, rival <= 0.8": either(default_rule, confident(0.9, 0.8)),
    "+ evidence >= 0.95, rival <= 0.85": either(default_rule, confident(0.95, 0.85)),
    "+ contradictions 2x + 0.1, agr 0.85, known 0.65":
        either(default_rule, contradictions(2, 0.1, 0.85, 0.65)),
    "+ contradictions 3x + 0.05, agr 0.9, known 0.65":
        either(default_rule, contradictions(3, 0.05, 0.9, 0.65)),
}


def main(paths):
    if not paths:
        sys.exit(__doc__)
    try:
        traces = [load(p) for p in paths]
    except OSError as e:
        sys.exit(f"replay-declaration-rules: {e}")
    for name, rule in RULES.items():
        rows = [replay(t, rule) for t in traces]
        total = [sum(r[k] for r in rows) for k in range(3)]
        cells = "  ".join("%d/%d/%d" % r for r in rows)
        print(f"{name:50s} {cells}  all {'/'.join(map(str, total))}")


if __name__ == "__main__":
    main(sys.argv[1:])
