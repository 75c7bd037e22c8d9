#!/usr/bin/env python3
"""Lists the longest functions of each folder (C++ definitions starting at column 0, counted
from the signature to the closing brace; lambdas count toward the function around them).

usage: tools/function-lengths.py [--top N] FOLDER [FOLDER ...]
  e.g. tools/function-lengths.py leader follower fleet sim bench app
"""
import argparse
import os
import re

SKIP = ('//', '#', 'namespace', '}', 'struct', 'class', 'enum', 'using', 'template', 'extern',
        'static_assert', 'inline constexpr', 'constexpr', 'typedef')


def functions(path):
    """(lines, name, first line) of every function defined at column 0 in `path`."""
    with open(path, encoding='utf-8') as f:
        lines = f.read().split('\n')
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        if not line or line[0].isspace() or line.startswith(SKIP) or '(' not in line:
            i += 1
            continue
        j = i
        while j < len(lines) and '{' not in lines[j] and not lines[j].rstrip().endswith(';'):
            j += 1
        if j >= len(lines) or '{' not in lines[j]:
            i = j + 1
            continue
        depth, k = 0, j
        while k < len(lines):
            depth += lines[k].count('{') - lines[k].count('}')
            if depth <= 0:
                break
            k += 1
        name = re.sub(r'\s+', ' ', line.split('(')[0]).split(' ')[-1]
        out.append((k - i + 1, name, i + 1))
        i = k + 1
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--top', type=int, default=3)
    ap.add_argument('folders', nargs='+')
    a = ap.parse_args()
    for folder in a.folders:
        found = []
        for d, _, files in os.walk(folder):
            for name in files:
                if name.endswith(('.cpp', '.hpp')):
                    p = os.path.join(d, name)
                    found += [(n, f'{p}:{line}', fn) for n, fn, line in functions(p)]
        found.sort(reverse=True)
        print(f'{folder}: ' + ', '.join(f'{fn} {n} ({where})' for n, where, fn in found[:a.top]))


if __name__ == '__main__':
    main()
