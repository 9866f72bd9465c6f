#!/usr/bin/env python3
"""Programs of one mode each, for docs/performance.md's per-mode instruction counts.

    python3 tools/mode_programs.py MODE [N] > program

MODE: `plane` (G68.2 tilted working plane, N random G1 moves in it), `plane_tnc` (the
same moves under a TNC PLANE SPATIAL), `same` (the plane's kind of motion in machine
axes: A and C standing, X, Y, Z moving), `arc` (N G3 arcs of 10 degrees at A-20),
`cycle` (N G81 holes at A-20). Random, but the same every run (seed 7). For the AC
trunnion (fixtures/ac_trunnion.machine.toml).
"""
import math
import random
import sys


def walk(n):
    x = y = z = 0.0
    for _ in range(n):
        x = min(40, max(-40, x + random.uniform(-1, 1)))
        y = min(40, max(-40, y + random.uniform(-1, 1)))
        z = min(0, max(-5, z + random.uniform(-0.05, 0.05)))
        yield x, y, z


def gcode(kind, n):
    lines = ['G21 G90 G94 G17 G40 G49 G80', 'T1 M6', 'G54']
    add = lines.append
    if kind == 'plane':
        add('G0 X0 Y0 Z150. A0 C0')
        add('G68.2 X10. Y5. Z0 I10. J25. K-10.')
        add('G53.1')
        add('G43 H1 Z50.')
    elif kind == 'same':
        add('G43 H1')
        add('G0 X0 Y0 Z150. A-25. C10.')
    if kind in ('plane', 'same'):
        add('G0 X0 Y0 Z20.')
        add('G1 Z0 F300.')
        for x, y, z in walk(n):
            add('G1 X%.4f Y%.4f Z%.4f' % (x, y, z))
        add('G0 Z50.')
        if kind == 'plane':
            add('G69')
    elif kind == 'arc':
        add('G43 H1')
        add('G0 X30. Y0 Z20. A-20. C0')
        add('G1 Z2. F800')
        px, py = 30.0, 0.0
        for i in range(1, n + 1):
            a = math.radians(10 * i)
            x, y = 30 * math.cos(a), 30 * math.sin(a)
            add('G3 X%.4f Y%.4f I%.4f J%.4f F500' % (x, y, -px, -py))
            px, py = x, y
        add('G0 Z60.')
    elif kind == 'cycle':
        add('G43 H1')
        add('G0 X0 Y0 Z30. A-20. C0')
        add('G98 G81 X0 Y0 Z-1. R1. F200.')
        for _ in range(n):
            add('X%.3f Y%.3f' % (random.uniform(-60, 60), random.uniform(-60, 60)))
        add('G80')
        add('G0 Z60.')
    add('G49')
    add('M30')
    numbered = ['N%d %s' % (10 * (i + 1), l) for i, l in enumerate(lines)]
    return '\n'.join(['%', 'O0100 (PERF %s)' % kind.upper()] + numbered + ['%'])


def tnc(n):
    lines = ['BEGIN PGM PLANE MM', 'TOOL CALL 1 Z S8000', 'L X+0 Y+0 Z+150 A+0 C+0 R0 FMAX',
             'PLANE SPATIAL SPA-25 SPB+0 SPC+10 TURN FMAX SEQ- TABLE ROT',
             'L X+0 Y+0 Z+20 R0 FMAX', 'L Z+0 F300']
    lines += ['L X%+.4f Y%+.4f Z%+.4f' % p for p in walk(n)]
    lines += ['L Z+50 R0 FMAX', 'PLANE RESET STAY', 'M30', 'END PGM PLANE MM']
    return '\n'.join('%d %s' % (i, l) for i, l in enumerate(lines))


if __name__ == '__main__':
    random.seed(7)
    kind = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 10000
    print(tnc(n) if kind == 'plane_tnc' else gcode(kind, n))
