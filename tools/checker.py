#!/usr/bin/env python3
"""Independent outside checker for nccomp.

Implements the machine and error model of the project's contract
(../shared/design/model.md, beside the repository) from its text alone, in pure
Python (standard library only), and uses it to check compensated NC programs:

  evaluate   compare a program and its compensated version pose by pose
  generate   write a random AC trunnion machine, error file and program
  roundtrip  generate, run nccomp, evaluate, for a range of seeds

See tools/README.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import subprocess
import sys
import tempfile
import tomllib

# --------------------------------------------------------------------------------------
# Small linear algebra: 3-vectors as tuples, 3x3 matrices as tuples of rows, rigid
# transforms as (R, t) acting on column vectors: x -> R x + t.
# --------------------------------------------------------------------------------------

I3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
ZERO3 = (0.0, 0.0, 0.0)


def vadd(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def vsub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def vscale(s, a):
    return (s * a[0], s * a[1], s * a[2])


def vdot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def vcross(a, b):
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def vnorm(a):
    return math.sqrt(vdot(a, a))


def vunit(a):
    n = vnorm(a)
    if n == 0.0:
        raise ValueError("zero direction vector")
    return vscale(1.0 / n, a)


def angle_between(a, b):
    """Angle between two vectors in rad, accurate for tiny angles."""
    return math.atan2(vnorm(vcross(a, b)), vdot(a, b))


def mmul(A, B):
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = B
    return tuple(
        (a0 * b00 + a1 * b10 + a2 * b20, a0 * b01 + a1 * b11 + a2 * b21,
         a0 * b02 + a1 * b12 + a2 * b22)
        for a0, a1, a2 in A
    )


def mvec(A, v):
    x, y, z = v
    return tuple(a0 * x + a1 * y + a2 * z for a0, a1, a2 in A)


def mtrans(A):
    return tuple(tuple(A[j][i] for j in range(3)) for i in range(3))


def rotvec(e):
    """Rv(e): the rotation whose rotation vector is e (angle |e| about e/|e|)."""
    th = vnorm(e)
    if th == 0.0:
        return I3
    k = vscale(1.0 / th, e)
    s = math.sin(th)
    v = 2.0 * math.sin(th / 2.0) ** 2  # 1 - cos(th), without cancellation
    c = 1.0 - v
    x, y, z = k
    return (
        (c + v * x * x, v * x * y - s * z, v * x * z + s * y),
        (v * y * x + s * z, c + v * y * y, v * y * z - s * x),
        (v * z * x - s * y, v * z * y + s * x, c + v * z * z),
    )


def rot(a, theta):
    """Rot(a, theta): right-handed rotation by theta (rad) about unit vector a."""
    return rotvec(vscale(theta, vunit(a)))


IDENTITY = (I3, ZERO3)


def tcompose(A, B):
    """A * B for rigid transforms (B applied first)."""
    Ra, ta = A
    Rb, tb = B
    return (mmul(Ra, Rb), vadd(mvec(Ra, tb), ta))


def tinverse(A):
    R, t = A
    Rt = mtrans(R)
    return (Rt, vscale(-1.0, mvec(Rt, t)))


def tpoint(A, p):
    R, t = A
    return vadd(mvec(R, p), t)


# --------------------------------------------------------------------------------------
# Model files
# --------------------------------------------------------------------------------------

LENGTH_UNITS = {"mm": 1.0, "um": 1e-3}
ANGLE_UNITS = {
    "rad": 1.0,
    "urad": 1e-6,
    "deg": math.pi / 180.0,
    "arcsec": math.pi / (180.0 * 3600.0),
}
COMPONENTS = "XYZABC"
AXIS_NAME = re.compile(r"^[A-Z][A-Z0-9]*$")
TERM = re.compile(r"^E([XYZABC])(0?)([A-Z][A-Z0-9]*)$")


class ModelError(Exception):
    pass


class Axis:
    def __init__(self, name, spec):
        known = {"kind", "direction", "point", "travel", "reference_point", "table_offset", "word"}
        unknown = set(spec) - known
        if unknown:
            raise ModelError(f"axis {name}: unknown keys {sorted(unknown)}")
        if not AXIS_NAME.match(name):
            raise ModelError(f"bad axis name {name!r}")
        self.name = name
        self.kind = spec.get("kind")
        if self.kind not in ("linear", "rotary"):
            raise ModelError(f"axis {name}: kind must be linear or rotary")
        self.direction = vunit(tuple(float(x) for x in spec["direction"]))
        self.word = spec.get("word", name[0]).upper()
        if self.kind == "rotary":
            self.point = tuple(float(x) for x in spec.get("point", (0, 0, 0)))
        else:
            self.point = tuple(float(x) for x in spec.get("reference_point", (0, 0, 0)))
        self.travel = spec.get("travel")
        self.table_offset = float(spec.get("table_offset", 0.0))
        # own direction: coordinate axis with the largest |component|, first on a tie
        d = [abs(x) for x in self.direction]
        own = 0
        for i in (1, 2):
            if d[i] > d[own]:
                own = i
        self.own = own

    @property
    def rotary(self):
        return self.kind == "rotary"


class Machine:
    def __init__(self, path, tool_chain=None):
        with open(path, "rb") as f:
            data = tomllib.load(f)
        known = {
            "name", "workpiece_chain", "tool_chain", "tool_chains", "resolution", "axes", "tool",
        }
        unknown = set(data) - known
        if unknown:
            raise ModelError(f"{path}: unknown keys {sorted(unknown)}")
        self.name = data.get("name", "")
        self.axes = {n: Axis(n, s) for n, s in data.get("axes", {}).items()}
        self.workpiece_chain = list(data.get("workpiece_chain", []))
        if "tool_chains" in data:
            chains = dict(data["tool_chains"])
        else:
            chains = {"tool": list(data.get("tool_chain", []))}
        if tool_chain is None:
            tool_chain = next(iter(chains))
        if tool_chain not in chains:
            raise ModelError(f"no tool chain {tool_chain!r} (have {list(chains)})")
        self.tool_chain_name = tool_chain
        self.tool_chain = list(chains[tool_chain])
        for n in self.workpiece_chain + [a for c in chains.values() for a in c]:
            if n not in self.axes:
                raise ModelError(f"chain names unknown axis {n}")
        tool = data.get("tool", {})
        self.tool_length = float(tool.get("length", 0.0))
        self.tool_lengths = {int(k): float(v) for k, v in tool.get("lengths", {}).items()}
        # program words of the active chains
        self.active = self.workpiece_chain + self.tool_chain
        self.word_axis = {}
        for n in self.active:
            w = self.axes[n].word
            if w in self.word_axis:
                raise ModelError(f"axes {self.word_axis[w]} and {n} share word {w}")
            self.word_axis[w] = n

    def rotary_active(self):
        return [n for n in self.active if self.axes[n].rotary]


class Table:
    """Error motion table of one axis: six columns (X Y Z in mm, A B C in rad)."""

    def __init__(self, positions, columns, periodic):
        order = sorted(range(len(positions)), key=lambda i: positions[i])
        self.pos = [float(positions[i]) for i in order]
        self.cols = {c: [v[i] for i in order] for c, v in columns.items()}
        self.periodic = periodic
        if len(set(self.pos)) != len(self.pos):
            raise ModelError("duplicate table positions")
        if periodic and len(self.pos) > 1:
            span = self.pos[-1] - self.pos[0]
            if span > 360.0:
                raise ModelError("rotary table positions span more than 360 degrees")
            if span == 360.0:
                for c, v in self.cols.items():
                    if abs(v[0] - v[-1]) > 1e-12 * max(1.0, abs(v[0])):
                        raise ModelError(
                            f"E{COMPONENTS[c]}: different values at {self.pos[0]} and "
                            f"{self.pos[-1]} degrees, the same angle")

    def evaluate(self, x):
        """Returns ({component: value}, beyond_ends)."""
        pos = self.pos
        n = len(pos)
        out = {}
        if n == 1:
            return {c: v[0] for c, v in self.cols.items()}, False
        if self.periodic:
            p0 = pos[0]
            x = p0 + math.fmod(x - p0, 360.0)
            if x < p0:
                x += 360.0
            if x >= p0 + 360.0:
                x -= 360.0
            if x <= pos[-1]:
                i = self._segment(x)
                for c, v in self.cols.items():
                    out[c] = self._lerp(pos[i], v[i], pos[i + 1], v[i + 1], x)
            else:  # wrap segment from the last position to the first + 360
                for c, v in self.cols.items():
                    out[c] = self._lerp(pos[-1], v[-1], p0 + 360.0, v[0], x)
            return out, False
        if x <= pos[0]:
            return {c: v[0] for c, v in self.cols.items()}, x < pos[0]
        if x >= pos[-1]:
            return {c: v[-1] for c, v in self.cols.items()}, x > pos[-1]
        i = self._segment(x)
        for c, v in self.cols.items():
            out[c] = self._lerp(pos[i], v[i], pos[i + 1], v[i + 1], x)
        return out, False

    def _segment(self, x):
        pos = self.pos
        for i in range(len(pos) - 1):
            if x <= pos[i + 1]:
                return i
        return len(pos) - 2

    @staticmethod
    def _lerp(x0, y0, x1, y1, x):
        if x1 == x0:
            return y0
        f = (x - x0) / (x1 - x0)
        return y0 + f * (y1 - y0)


class AxisErrors:
    def __init__(self):
        self.square = [0.0, 0.0, 0.0]  # s, rad (linear)
        self.shift = [0.0, 0.0, 0.0]  # c~ - c, mm (rotary)
        self.tilt = [0.0, 0.0, 0.0]  # tilt rotation vector, rad (rotary)
        self.e0 = 0.0  # rad (rotary)
        self.table = None

    def is_zero(self):
        if any(self.square) or any(self.shift) or any(self.tilt) or self.e0:
            return False
        if self.table is not None:
            return not any(any(v) for v in self.table.cols.values())
        return True


class Errors:
    def __init__(self, machine, path=None, zero=False):
        self.axes = {n: AxisErrors() for n in machine.axes}
        self.beyond = set()  # axes whose tables were read beyond their ends
        if zero or path is None:
            return
        with open(path, "rb") as f:
            data = tomllib.load(f)
        unknown = set(data) - {"length_unit", "angle_unit", "squareness", "location", "motion"}
        if unknown:
            raise ModelError(f"{path}: unknown keys {sorted(unknown)}")
        lu = data.get("length_unit", "um")
        au = data.get("angle_unit", "urad")
        if lu not in LENGTH_UNITS or au not in ANGLE_UNITS:
            raise ModelError(f"{path}: bad units {lu!r} / {au!r}")
        self.lscale = LENGTH_UNITS[lu]
        self.ascale = ANGLE_UNITS[au]

        def parse(name, section_axis=None):
            m = TERM.match(name)
            if not m:
                raise ModelError(f"{path}: unknown error name {name!r}")
            comp, zero_flag, axis = m.group(1), m.group(2) == "0", m.group(3)
            if axis not in machine.axes:
                raise ModelError(f"{path}: {name}: no axis {axis}")
            if section_axis is not None and axis != section_axis:
                raise ModelError(f"{path}: {name} is not a term of axis {section_axis}")
            return COMPONENTS.index(comp), zero_flag, machine.axes[axis]

        def scale(ci):
            return self.lscale if ci < 3 else self.ascale

        for name, value in data.get("squareness", {}).items():
            ci, const, ax = parse(name)
            if not const or ax.rotary or ci < 3:
                raise ModelError(f"{path}: {name} is not a squareness term of a linear axis")
            if ci - 3 == ax.own:
                raise ModelError(f"{path}: {name} is about the axis's own direction")
            self.axes[ax.name].square[ci - 3] = float(value) * scale(ci)
        for axname, terms in data.get("location", {}).items():
            if axname not in machine.axes or not machine.axes[axname].rotary:
                raise ModelError(f"{path}: location errors of non-rotary/unknown axis {axname}")
            for name, value in terms.items():
                ci, const, ax = parse(name, axname)
                if not const:
                    raise ModelError(f"{path}: {name} is not a location term")
                ae = self.axes[axname]
                v = float(value) * scale(ci)
                if ci < 3:
                    if ci == ax.own:
                        raise ModelError(f"{path}: {name} shifts the axis along its own line")
                    ae.shift[ci] = v
                elif ci - 3 == ax.own:
                    ae.e0 = v
                else:
                    ae.tilt[ci - 3] = v
        for axname, spec in data.get("motion", {}).items():
            if axname not in machine.axes:
                raise ModelError(f"{path}: motion table of unknown axis {axname}")
            ax = machine.axes[axname]
            if "positions" not in spec:
                raise ModelError(f"{path}: motion.{axname} has no positions")
            positions = [float(x) for x in spec["positions"]]
            cols = {}
            for name, values in spec.items():
                if name == "positions":
                    continue
                ci, const, _ = parse(name, axname)
                if const:
                    raise ModelError(f"{path}: {name} is not an error motion")
                if len(values) != len(positions):
                    raise ModelError(f"{path}: {name} has {len(values)} values")
                cols[ci] = [float(v) * scale(ci) for v in values]
            self.axes[axname].table = Table(positions, cols, ax.rotary)

    def is_zero(self):
        return all(a.is_zero() for a in self.axes.values())


# --------------------------------------------------------------------------------------
# Kinematics: the contract's joint transforms and the pose seen from the workpiece
# --------------------------------------------------------------------------------------


def joint(axis, q, errs):
    """J(q) of one axis; errs is an AxisErrors or None (nominal)."""
    delta = ZERO3
    eps = ZERO3
    beyond = False
    if errs is not None and errs.table is not None:
        vals, beyond = errs.table.evaluate(q + axis.table_offset)
        delta = tuple(vals.get(i, 0.0) for i in range(3))
        eps = tuple(vals.get(i, 0.0) for i in range(3, 6))
    Re = rotvec(eps)
    if not axis.rotary:
        d = axis.direction
        if errs is not None:
            d = mvec(rotvec(tuple(errs.square)), d)
        r = axis.point
        # Tr(q d~) Tr(r) Tr(delta) Rv(eps) Tr(-r)
        t = vadd(vadd(vscale(q, d), r), vsub(delta, mvec(Re, r)))
        return (Re, t), beyond
    a = axis.direction
    c = axis.point
    e0 = 0.0
    if errs is not None:
        c = vadd(c, tuple(errs.shift))
        a = mvec(rotvec(tuple(errs.tilt)), a)
        e0 = errs.e0
    R = mmul(Re, rot(a, math.radians(q) + e0))
    # Tr(c~) Tr(delta) Rv(eps) Rot(a~, q + e0) Tr(-c~)
    t = vadd(vadd(c, delta), vscale(-1.0, mvec(R, c)))
    return (R, t), beyond


def chain(machine, names, q, errors):
    """Returns (T, [(axis name, prefix transform up to and including it)])."""
    T = IDENTITY
    prefixes = []
    for n in names:
        ax = machine.axes[n]
        J, beyond = joint(ax, q[n], errors.axes[n] if errors is not None else None)
        if beyond and errors is not None:
            errors.beyond.add(n)
        T = tcompose(T, J)
        prefixes.append((n, T))
    return T, prefixes


def pose(machine, q, tool_length, errors=None):
    """(p, o, rotary axis lines in the workpiece frame) for axis values q (mm, deg)."""
    W, wpre = chain(machine, machine.workpiece_chain, q, errors)
    T, tpre = chain(machine, machine.tool_chain, q, errors)
    Winv = tinverse(W)
    M = tcompose(Winv, T)
    tip = (0.0, 0.0, -(tool_length - machine.tool_length))
    p = tpoint(M, tip)
    o = mvec(M[0], (0.0, 0.0, 1.0))
    lines = {}
    for n, P in wpre + tpre:
        ax = machine.axes[n]
        if ax.rotary:
            # the axis direction after its own joint equals the one before it
            lines[n] = mvec(Winv[0], mvec(P[0], ax.direction))
    return p, o, lines


# --------------------------------------------------------------------------------------
# NC programs
# --------------------------------------------------------------------------------------

WORD = re.compile(r"([A-Za-z])\s*([+-]?\s*(?:\d+\.?\d*|\.\d+))")


class ProgramError(Exception):
    pass


def strip_comments(line):
    out = []
    depth = 0
    for ch in line:
        if depth:
            if ch == ")":
                depth -= 1
            continue
        if ch == "(":
            depth += 1
            continue
        if ch == ";":
            break
        out.append(ch)
    return "".join(out)


class Block:
    __slots__ = ("lineno", "text", "q", "tool", "words", "motion")

    def __init__(self, lineno, text, q, tool, words, motion):
        self.lineno = lineno
        self.text = text
        self.q = q  # modal axis values after the block (mm, deg)
        self.tool = tool  # active tool length (mm)
        self.words = words  # axis words on the line: {axis name: value as written}
        self.motion = motion


def read_program(path, machine):
    with open(path, "r", encoding="utf-8", newline="") as f:
        text = f.read()
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    q = {n: 0.0 for n in machine.active}
    tool = machine.tool_length
    inch = False
    incremental = False
    motion = 0
    blocks = []
    for i, raw in enumerate(lines, start=1):
        line = raw.rstrip("\r")
        body = strip_comments(line).strip()
        if body.startswith("%"):
            body = ""
        words = []
        for m in WORD.finditer(body):
            words.append((m.group(1).upper(), float(m.group(2).replace(" ", ""))))
        leftover = WORD.sub("", body).strip()
        leftover = re.sub(r"[/\s]", "", leftover)
        if leftover:
            raise ProgramError(f"{path}:{i}: cannot read {leftover!r} in {line!r}")
        gs = [v for letter, v in words if letter == "G"]
        for g in gs:
            if g == 20:
                inch = True
            elif g == 21:
                inch = False
            elif g == 90:
                incremental = False
            elif g == 91:
                incremental = True
            elif g in (0, 1):
                motion = int(g)
            elif g in (2, 3):
                raise ProgramError(f"{path}:{i}: arcs (G{int(g)}) are not supported")
        if 43 in gs:
            hs = [v for letter, v in words if letter == "H"]
            if hs:
                h = int(hs[-1])
                if h not in machine.tool_lengths:
                    raise ProgramError(f"{path}:{i}: H{h} is not in the machine's tool table")
                tool = machine.tool_lengths[h]
        if 49 in gs:
            tool = machine.tool_length
        axis_words = {}
        for letter, v in words:
            if any(g in gs for g in (4, 10, 92)):
                break  # dwell (G4 X = time) and offset settings carry no axis positions
            if letter in machine.word_axis:
                n = machine.word_axis[letter]
                if n in axis_words:
                    raise ProgramError(f"{path}:{i}: axis word {letter} twice")
                ax = machine.axes[n]
                val = v * 25.4 if (inch and not ax.rotary) else v
                axis_words[n] = val
                q[n] = q[n] + val if incremental else val
        blocks.append(Block(i, line, dict(q), tool, axis_words, motion))
    return text, blocks


# --------------------------------------------------------------------------------------
# path: aligning split moves and sampling the compensated path
# --------------------------------------------------------------------------------------

ALIGN_TIP_UM = 2.0     # an output block this close to an input block's end is that block
ALIGN_DIR_URAD = 50.0
ON_PATH_UM = 50.0      # an inserted block must lie this close to the move's nominal path
MAX_INSERTED = 4096
QUARTERS = (0.25, 0.5, 0.75)


def lerp_q(a, b, s):
    return {k: a[k] + (b[k] - a[k]) * s for k in a}


def closest_on_path(machine, qa, qb, tool, p, ta=0.0, tb=1.0, within=None):
    """(distance mm, t) from point p to the nominal tip path q(t) = lerp(qa, qb, t), t in
    [ta, tb]: the first local minimum (marching from ta) closer than `within` mm, refined by
    golden-section search; without `within`, the closest of all local minima. A move can
    pass the same place twice (a rotary axis turning more than a revolution): marching from
    ta finds the pass that comes first."""
    def dist(t):
        pn, _, _ = pose(machine, lerp_q(qa, qb, t), tool)
        return vnorm(vsub(p, pn))

    def refine(lo, hi):
        g = (math.sqrt(5.0) - 1.0) / 2.0
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        f1, f2 = dist(x1), dist(x2)
        for _ in range(24):
            if f1 < f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - g * (hi - lo)
                f1 = dist(x1)
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + g * (hi - lo)
                f2 = dist(x2)
        return min((f1, x1), (f2, x2))

    steps = max(4, int(math.ceil((tb - ta) * 256)))
    h = (tb - ta) / steps
    best = (dist(ta), ta)
    d_prev2, d_prev = None, best[0]
    for k in range(1, steps + 1):
        t = ta + k * h
        d = dist(t)
        candidates = []
        if d_prev2 is not None and d_prev <= d_prev2 and d_prev <= d:
            candidates.append(refine(max(t - 2 * h, ta), t))
        if k == 1 and d_prev <= d:
            candidates.append(refine(ta, t))
        if k == steps and d <= d_prev:
            candidates.append(refine(t - h, t))
        for cand in candidates:
            if within is not None and cand[0] <= within:
                return cand
            best = min(best, cand)
        d_prev2, d_prev = d_prev, d
    return min(best, (d_prev, tb))


def is_end_of(machine, errors, bi, bo):
    """Whether output block bo puts the real machine where input block bi ends."""
    p_nom, o_nom, lines = pose(machine, bi.q, bi.tool)
    p_err, o_err, _ = pose(machine, bo.q, bo.tool, errors)
    if vnorm(vsub(p_err, p_nom)) * 1000.0 > ALIGN_TIP_UM:
        return False
    if angle_between(o_err, o_nom) * 1e6 <= ALIGN_DIR_URAD:
        return True
    # At a singular pose the direction is not held; the tip decides.
    for line in lines.values():
        ang = math.degrees(angle_between(o_nom, line))
        if min(ang, 180.0 - ang) < SINGULAR_DEG:
            return True
    return False


def align(machine, errors, prog_in, prog_out, problems):
    """Pair every input line with its output line. A split move arrives as inserted blocks
    before its own block: each is a G1 block that puts the real machine on the nominal path
    of the move (not at its end). Returns [(input block, output block, [(inserted block,
    t on the nominal path)])] and adds what does not line up to `problems`."""
    pairs = []
    j = 0
    prev_in = None
    for bi in prog_in:
        inserted = []
        if bi.words and prev_in is not None and bi.motion == 1:
            t_prev = 0.0
            while (j < len(prog_out) and prog_out[j].words and prog_out[j].motion == 1
                   and len(inserted) < MAX_INSERTED
                   and not is_end_of(machine, errors, bi, prog_out[j])):
                bo = prog_out[j]
                p_err, _, _ = pose(machine, bo.q, bo.tool, errors)
                d, t = closest_on_path(machine, prev_in.q, bi.q, bi.tool, p_err, t_prev, 1.0,
                                       within=ON_PATH_UM / 1000.0)
                if d * 1000.0 > ON_PATH_UM or t >= 1.0 - 1e-12:
                    break  # not a piece of this move: the block's own (bad) end
                inserted.append((bo, t))
                t_prev = t
                j += 1
        if j >= len(prog_out):
            problems.append(f"input line {bi.lineno} has no output line")
            break
        pairs.append((bi, prog_out[j], inserted))
        j += 1
        if bi.words:
            prev_in = bi
    if j < len(prog_out):
        problems.append(f"output has {len(prog_out) - j} lines after the last input line "
                        f"(from line {prog_out[j].lineno})")
    return pairs


def check_path(machine, errors, a_in, bi, a_out, pieces, s):
    """Sample each compensated segment of the move a_in -> bi at its quarter points: the real
    machine's tip there against the nominal path of the move. pieces: [(output block, t)],
    the move's own output block last with t = 1."""
    qa_out, ta = a_out.q, 0.0
    for bo, tb in pieces:
        for f in QUARTERS:
            qc = lerp_q(qa_out, bo.q, f)
            pc, oc, _ = pose(machine, qc, bo.tool, errors)
            t_guess = ta + (tb - ta) * f
            qn = lerp_q(a_in.q, bi.q, t_guess)
            pn, on, lines = pose(machine, qn, bi.tool)
            d = vnorm(vsub(pc, pn))
            if d * 1000.0 > (s["tolerances"]["path_um"] or 1.0):
                # The same-parameter distance bounds the distance to the path (and is what
                # is reported where it is within tolerance); look for the closest point only
                # where it matters.
                d, t = closest_on_path(machine, a_in.q, bi.q, bi.tool, pc,
                                       max(ta - 0.05, 0.0), min(tb + 0.05, 1.0))
                pn, on, lines = pose(machine, lerp_q(a_in.q, bi.q, t), bi.tool)
            s["path_samples"] += 1
            um = d * 1000.0
            if um > s["path_max_um"]:
                s["path_max_um"], s["path_max_line"] = um, bo.lineno
            tol = s["tolerances"]["path_um"]
            if tol is not None and um > tol:
                s["path_over_tol"] += 1
            singular = any(min(a, 180.0 - a) < SINGULAR_DEG
                           for a in (math.degrees(angle_between(on, l)) for l in lines.values()))
            if not singular:
                ang = angle_between(oc, on) * 1e6
                if ang > s["path_max_dir_urad"]:
                    s["path_max_dir_urad"], s["path_max_dir_line"] = ang, bo.lineno
            if f == 0.5:
                pu, _, _ = pose(machine, qn, bi.tool, errors)
                pn0, _, _ = pose(machine, qn, bi.tool)
                s["uncompensated_path_max_um"] = max(s["uncompensated_path_max_um"],
                                                     vnorm(vsub(pu, pn0)) * 1000.0)
        qa_out, ta = bo.q, tb


# --------------------------------------------------------------------------------------
# evaluate
# --------------------------------------------------------------------------------------

SINGULAR_DEG = 3.0
TOL_TIP_UM = 1.0
TOL_DIR_URAD = 10.0
TOL_SWING_DEG = 0.001


def evaluate(machine_path, errors_path, in_path, out_path, tool_chain=None, verbose=False,
             tol_tip_um=TOL_TIP_UM, tol_dir_urad=TOL_DIR_URAD, tol_swing_deg=TOL_SWING_DEG,
             tol_path_um=None):
    machine = Machine(machine_path, tool_chain)
    errors = Errors(machine, errors_path)
    in_text, prog_in = read_program(in_path, machine)
    out_text, prog_out = read_program(out_path, machine)
    rotaries = machine.rotary_active()
    # The direction can only be required where there are enough axes for it
    direction_required = len(machine.active) >= 5 and len(rotaries) >= 2
    s = {
        "machine": machine_path,
        "input": in_path,
        "output": out_path,
        "tool_chain": machine.tool_chain_name,
        "lines_in": len(prog_in),
        "lines_out": len(prog_out),
        "blocks_checked": 0,
        "max_tip_um": 0.0,
        "max_tip_line": None,
        "max_dir_urad": 0.0,
        "max_dir_line": None,
        "direction_required": direction_required,
        "singular": 0,
        "moves_checked": 0,
        "inserted_blocks": 0,
        "moves_after_tool_change": 0,
        "path_samples": 0,
        "path_max_um": 0.0,
        "path_max_line": None,
        "path_over_tol": 0,
        "path_max_dir_urad": 0.0,
        "path_max_dir_line": None,
        "uncompensated_path_max_um": 0.0,
        "least_squares": 0,
        "least_squares_max_unremovable_um": 0.0,
        "singular_max_tip_um": 0.0,
        "singular_max_tip_line": None,
        "singular_max_swing_deg": 0.0,
        "singular_max_swing_line": None,
        "uncompensated_max_tip_um": 0.0,
        "uncompensated_max_dir_urad": 0.0,
        "zero_model": errors.is_zero(),
        "tolerances": {"tip_um": tol_tip_um, "dir_urad": tol_dir_urad,
                       "swing_deg": tol_swing_deg, "path_um": tol_path_um},
        "problems": [],
        "tables_beyond_ends": [],
    }
    problems = s["problems"]
    if s["zero_model"] and in_text != out_text:
        problems.append("zero error model but the output is not byte-identical to the input")
    details = []
    pairs = align(machine, errors, prog_in, prog_out, problems)
    prev = None  # (input block, output block) of the previous programmed pose
    for bi, bo, inserted in pairs:
        s["inserted_blocks"] += len(inserted)
        if bi.words and prev is not None and bi.motion == 1:
            # The controller interpolates axis values linearly between blocks: sample every
            # compensated segment of the move against the move's nominal path (with the
            # tool active in the move: a G43 between blocks changes the tip, not the axes).
            if prev[0].tool == bi.tool:
                s["moves_checked"] += 1
                check_path(machine, errors, prev[0], bi, prev[1], inserted + [(bo, 1.0)], s)
            else:
                # A G43 between the blocks changed the tip while the axes stood still: the
                # move starts from a pose compensated for the previous tool, an error at
                # s = 0 that no choice of this block's axis values removes.
                s["moves_after_tool_change"] += 1
        elif inserted:
            problems.append(f"line {bi.lineno}: blocks inserted before a move that is not G1")
        if bi.words:
            prev = (bi, bo)
        if not bi.words:
            if bo.words:
                problems.append(f"line {bo.lineno}: output moves axes where the input does not")
            continue
        if bi.tool != bo.tool:
            problems.append(f"line {bi.lineno}: active tool differs between input and output")
        s["blocks_checked"] += 1
        p_nom, o_nom, lines = pose(machine, bi.q, bi.tool)
        p_err, o_err, _ = pose(machine, bo.q, bo.tool, errors)
        p_unc, o_unc, _ = pose(machine, bi.q, bi.tool, errors)
        tip = vnorm(vsub(p_err, p_nom)) * 1000.0
        dang = angle_between(o_err, o_nom) * 1e6
        utip = vnorm(vsub(p_unc, p_nom)) * 1000.0
        udir = angle_between(o_unc, o_nom) * 1e6
        s["uncompensated_max_tip_um"] = max(s["uncompensated_max_tip_um"], utip)
        s["uncompensated_max_dir_urad"] = max(s["uncompensated_max_dir_urad"], udir)
        singular_axes = []
        for n, line in lines.items():
            ang = math.degrees(angle_between(o_nom, line))
            if min(ang, 180.0 - ang) < SINGULAR_DEG:
                singular_axes.append(n)
        rec = {
            "line": bi.lineno,
            "tip_um": tip,
            "dir_urad": dang,
            "uncomp_tip_um": utip,
            "uncomp_dir_urad": udir,
            "singular": singular_axes,
        }
        # Where the free axes (those not held at a singular pose) cannot span the three
        # position equations, the contract asks for a least-squares solution: only the part
        # of the residual that moving the free axes could remove is then required to vanish.
        free = [n for n in machine.active if n not in singular_axes]
        removable = removable_part(machine, bo.q, bo.tool, errors, free,
                                   vsub(p_err, p_nom))
        if removable is not None:
            rec["unremovable_tip_um"] = tip
            s["least_squares"] += 1
            s["least_squares_max_unremovable_um"] = max(
                s["least_squares_max_unremovable_um"], tip)
            tip = removable * 1000.0
            rec["tip_um"] = tip
        if singular_axes:
            s["singular"] += 1
            swing = max(abs(bo.q[n] - bi.q[n]) for n in singular_axes)
            rec["swing_deg"] = swing
            if tip > s["singular_max_tip_um"]:
                s["singular_max_tip_um"], s["singular_max_tip_line"] = tip, bi.lineno
            if swing > s["singular_max_swing_deg"]:
                s["singular_max_swing_deg"], s["singular_max_swing_line"] = swing, bi.lineno
        else:
            if tip > s["max_tip_um"]:
                s["max_tip_um"], s["max_tip_line"] = tip, bi.lineno
            if dang > s["max_dir_urad"]:
                s["max_dir_urad"], s["max_dir_line"] = dang, bi.lineno
        details.append(rec)
    s["tables_beyond_ends"] = sorted(errors.beyond)
    fails = list(problems)
    if s["max_tip_um"] > tol_tip_um:
        fails.append(f"tip residual {s['max_tip_um']:.4f} um > {tol_tip_um} um "
                     f"(line {s['max_tip_line']})")
    if direction_required and s["max_dir_urad"] > tol_dir_urad:
        fails.append(f"direction residual {s['max_dir_urad']:.4f} urad > {tol_dir_urad} urad "
                     f"(line {s['max_dir_line']})")
    if s["singular_max_tip_um"] > tol_tip_um:
        fails.append(f"tip residual at singular poses {s['singular_max_tip_um']:.4f} um > "
                     f"{tol_tip_um} um (line {s['singular_max_tip_line']})")
    if s["singular_max_swing_deg"] > tol_swing_deg:
        fails.append(f"singular axis swung by {s['singular_max_swing_deg']:.6f} deg > "
                     f"{tol_swing_deg} deg (line {s['singular_max_swing_line']})")
    if tol_path_um is not None and s["path_max_um"] > tol_path_um:
        fails.append(f"path deviation {s['path_max_um']:.4f} um > {tol_path_um} um "
                     f"at {s['path_over_tol']} samples (worst at output line "
                     f"{s['path_max_line']})")
    s["failures"] = fails
    s["pass"] = not fails
    if verbose:
        s["blocks"] = details
    return s


def removable_part(machine, q, tool, errors, free, r):
    """None when the free axes span all three position directions at q; otherwise the
    length of the projection of the position residual r onto the span of the columns
    dp/dq_i of the free axes (the part a least-squares solution would have removed)."""
    h = 1e-3  # mm or degree
    beyond = set(errors.beyond)
    cols = []
    for n in free:
        qp = dict(q)
        qm = dict(q)
        qp[n] += h
        qm[n] -= h
        pp, _, _ = pose(machine, qp, tool, errors)
        pm, _, _ = pose(machine, qm, tool, errors)
        cols.append(vscale(1.0 / (2.0 * h), vsub(pp, pm)))
    errors.beyond = beyond
    basis = []
    for c in cols:
        n0 = vnorm(c)
        v = c
        for b in basis:
            v = vsub(v, vscale(vdot(v, b), b))
        nv = vnorm(v)
        if nv > 1e-9 and nv > 1e-6 * n0:
            basis.append(vscale(1.0 / nv, v))
    if len(basis) >= 3:
        return None
    proj = ZERO3
    for b in basis:
        proj = vadd(proj, vscale(vdot(r, b), b))
    return vnorm(proj)


def _ln(x):
    return "-" if x is None else str(x)


def print_summary(s, out=sys.stdout):
    w = out.write
    w(f"checked {s['output']} against {s['input']} (tool chain {s['tool_chain']})\n")
    w(f"  lines: input {s['lines_in']}, output {s['lines_out']}; "
      f"programmed poses checked: {s['blocks_checked']}\n")
    w(f"  uncompensated error: tip {s['uncompensated_max_tip_um']:.3f} um, "
      f"direction {s['uncompensated_max_dir_urad']:.3f} urad\n")
    w(f"  residual (non-singular): tip {s['max_tip_um']:.4f} um (line {_ln(s['max_tip_line'])}), "
      f"direction {s['max_dir_urad']:.4f} urad (line {_ln(s['max_dir_line'])})"
      f"{'' if s['direction_required'] else ' [not required: too few axes]'}\n")
    w(f"  singular poses: {s['singular']}, tip {s['singular_max_tip_um']:.4f} um "
      f"(line {_ln(s['singular_max_tip_line'])}), swing {s['singular_max_swing_deg']:.6g} deg "
      f"(line {_ln(s['singular_max_swing_line'])})\n")
    enforced = s["tolerances"]["path_um"] is not None
    w(f"  path of G1 moves{'' if enforced else ' (informational)'}: "
      f"{s['moves_checked']} moves, {s['inserted_blocks']} inserted blocks, "
      f"{s['path_samples']} quarter-point samples: max {s['path_max_um']:.3f} um "
      f"(output line {_ln(s['path_max_line'])}), {s['path_over_tol']} over "
      f"{s['tolerances']['path_um']} um; direction max {s['path_max_dir_urad']:.3f} urad "
      f"(output line {_ln(s['path_max_dir_line'])}); uncompensated max "
      f"{s['uncompensated_path_max_um']:.3f} um; {s['moves_after_tool_change']} moves "
      f"right after a tool length change not sampled\n")
    if s["least_squares"]:
        w(f"  least-squares poses (free axes cannot span the position): {s['least_squares']}, "
          f"unremovable tip error up to {s['least_squares_max_unremovable_um']:.3f} um "
          f"(only the removable part is checked)\n")
    if s["tables_beyond_ends"]:
        w(f"  note: tables read beyond their ends: {', '.join(s['tables_beyond_ends'])}\n")
    for f in s["failures"]:
        w(f"  FAIL: {f}\n")
    t = s["tolerances"]
    w(f"  verdict: {'PASS' if s['pass'] else 'FAIL'} "
      f"(tolerances {t['tip_um']} um, {t['dir_urad']} urad, swing {t['swing_deg']} deg)\n")


def cmd_evaluate(args):
    try:
        s = evaluate(args.machine, args.errors, args.input, args.output, args.tool_chain,
                     verbose=args.verbose, tol_tip_um=args.tip_tol, tol_dir_urad=args.dir_tol,
                     tol_swing_deg=args.swing_tol, tol_path_um=args.path_tol)
    except (ModelError, ProgramError, OSError, tomllib.TOMLDecodeError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(s, indent=2))
    else:
        print_summary(s)
        if args.verbose:
            for r in s["blocks"]:
                sing = f" singular {','.join(r['singular'])} swing {r['swing_deg']:.6g}" \
                    if r["singular"] else ""
                print(f"  line {r['line']}: tip {r['tip_um']:.4f} um dir {r['dir_urad']:.4f} urad"
                      f" (uncomp {r['uncomp_tip_um']:.3f} um {r['uncomp_dir_urad']:.3f} urad)"
                      f"{sing}")
    return 0 if s["pass"] else 1


# --------------------------------------------------------------------------------------
# generate
# --------------------------------------------------------------------------------------

LINEAR_TERMS = {  # valid position-independent terms of the linear axes of the AC trunnion
    "X": ["EB0X", "EC0X"],
    "Y": ["EA0Y", "EC0Y"],
    "Z": ["EA0Z", "EB0Z"],
}
LOCATION_TERMS = {
    "A": ["EY0A", "EZ0A", "EB0A", "EC0A", "EA0A"],
    "C": ["EX0C", "EY0C", "EA0C", "EB0C", "EC0C"],
}


def fmt(v):
    return repr(float(v))


def _vec(v):
    return "[" + ", ".join(fmt(x) for x in v) + "]"


def gen_machine(rng):
    """Random AC trunnion machine file text; returns (text, H numbers, A table offset)."""
    a_point = [0.0, round(rng.uniform(-5.0, 5.0), 3), -round(rng.uniform(40.0, 200.0), 3)]
    c_point = [round(rng.uniform(-0.5, 0.5), 4), round(rng.uniform(-0.5, 0.5), 4), 0.0]
    tool_length = rng.choice([0.0, 0.0, round(rng.uniform(50.0, 150.0), 2)])
    lengths = {}
    if rng.random() < 0.7:
        for h in rng.sample(range(1, 20), rng.randint(1, 3)):
            lengths[h] = round(rng.uniform(max(5.0, tool_length - 30.0), tool_length + 60.0), 3)
    out = [
        "# Random AC trunnion written by tools/checker.py generate",
        'name = "random AC trunnion"',
        'workpiece_chain = ["Y", "X", "A", "C"]',
        'tool_chain = ["Z"]',
    ]
    if rng.random() < 0.3:
        out.append("resolution = { linear = 0.0001, rotary = 0.0001 }")
    for ax, d in (("X", "[-1, 0, 0]"), ("Y", "[0, -1, 0]"), ("Z", "[0, 0, 1]")):
        out += ["", f"[axes.{ax}]", 'kind = "linear"', f"direction = {d}",
                "travel = [-450, 450]"]
        if rng.random() < 0.3:  # error reference point r
            r = [round(rng.uniform(-200.0, 200.0), 1) for _ in range(2)]
            r.append(round(rng.uniform(0.0, 400.0), 1))
            out.append(f"reference_point = {_vec(r)}")
        if rng.random() < 0.3:  # tables in machine coordinates
            out.append(f"table_offset = {fmt(round(rng.uniform(-500.0, 500.0), 2))}")
    a_offset = rng.choice([0.0, 0.0, 0.0, round(rng.uniform(-30.0, 30.0), 1)])
    out += ["", "[axes.A]", 'kind = "rotary"', "direction = [-1, 0, 0]",
            f"point = {_vec(a_point)}", "travel = [-120, 30]"]
    if a_offset:
        out.append(f"table_offset = {fmt(a_offset)}")
    out += ["", "[axes.C]", 'kind = "rotary"', "direction = [0, 0, -1]",
            f"point = {_vec(c_point)}"]
    if rng.random() < 0.3:
        out.append(f"table_offset = {fmt(round(rng.uniform(0.0, 360.0), 1))}")
    out += ["", "[tool]", f"length = {fmt(tool_length)}"]
    if lengths:
        out.append(
            "lengths = { " + ", ".join(f"{h} = {fmt(v)}" for h, v in sorted(lengths.items()))
            + " }"
        )
    return "\n".join(out) + "\n", sorted(lengths), a_offset


def gen_errors(rng, only=None, a_offset=0.0):
    """Random error file text. only: a term name (EXX, EC0Y, EX0C...), 'motion.AXIS',
    or 'none' for the zero model. a_offset: the A axis's table_offset."""
    lu = rng.choice(["um", "um", "mm"])
    au = rng.choice(["urad", "urad", "deg", "arcsec", "rad"])
    ls = LENGTH_UNITS[lu]
    as_ = ANGLE_UNITS[au]

    def length(sigma_um):
        return rng.gauss(0.0, sigma_um) * 1e-3 / ls

    def angle(sigma_urad):
        return rng.gauss(0.0, sigma_urad) * 1e-6 / as_

    def value(term, kind):
        comp = COMPONENTS.index(term[1])
        if comp < 3:
            return length(10.0 if kind == "motion" else 20.0)
        return angle(100.0)

    want = only  # None: every term at random

    def chosen(term):
        if want is None:
            return rng.random() < 0.6
        if want == "none":
            return False
        return term == want

    out = [
        "# Random error file written by tools/checker.py generate",
        f'length_unit = "{lu}"',
        f'angle_unit = "{au}"',
    ]
    sq = []
    for terms in LINEAR_TERMS.values():
        for t in terms:
            if chosen(t):
                sq.append(f"{t} = {fmt(value(t, 'square'))}")
    if sq:
        out += ["", "[squareness]"] + sq
    for ax, terms in LOCATION_TERMS.items():
        lines = [f"{t} = {fmt(value(t, 'location'))}" for t in terms if chosen(t)]
        if lines:
            out += ["", f"[location.{ax}]"] + lines
    for ax in ["X", "Y", "Z", "A", "C"]:
        cols = []
        for comp in COMPONENTS:
            t = f"E{comp}{ax}"
            if want == f"motion.{ax}" or chosen(t):
                cols.append(t)
        if not cols:
            continue
        n = rng.randint(3, 7)
        if ax in "XYZ":
            lo, hi = rng.uniform(-450.0, -100.0), rng.uniform(100.0, 450.0)
        elif ax == "A":  # cover the travel, so that periodicity never matters
            lo, hi = -120.0 + a_offset, 30.0 + a_offset
        else:  # periodic positions within [0, 360)
            lo = rng.uniform(0.0, 360.0 / n)
            hi = lo + 360.0 * (n - 1) / n
        step = (hi - lo) / (n - 1)
        pos = [lo + i * step + (rng.uniform(-0.3, 0.3) * step if 0 < i < n - 1 else 0.0)
               for i in range(n)]
        pos = [round(p, 3) for p in pos]
        out += ["", f"[motion.{ax}]", f"positions = [{', '.join(fmt(p) for p in pos)}]"]
        for t in cols:
            vals = [value(t, "motion") for _ in pos]
            out.append(f"{t} = [{', '.join(fmt(v) for v in vals)}]")
    return "\n".join(out) + "\n"


def gen_program(rng, blocks, hnums, seed):
    out = ["%", f"O{seed % 10000:04d} (RANDOM FIVE-AXIS PROGRAM, SEED {seed})"]
    n = 10

    def nline(text):
        nonlocal n
        out.append(f"N{n} {text}")
        n += 10

    nline("G21 G90")
    if hnums and rng.random() < 0.7:
        nline(f"T{hnums[0]} M6")
        nline(f"G43 H{hnums[0]}")
    nline("M3 S1000")
    q = {"X": 0.0, "Y": 0.0, "Z": 0.0, "A": 0.0, "C": 0.0}

    def num(v, dec):
        s = f"{v:.{dec}f}"
        if float(s) == 0.0:
            s = s.lstrip("-")
        return s

    def rand_axis(ax):
        if ax in "XY":
            return rng.uniform(-150.0, 150.0)
        if ax == "Z":
            return rng.uniform(-30.0, 150.0)
        if ax == "A":
            r = rng.random()
            if r < 0.15:
                return 0.0
            if r < 0.3:
                return rng.uniform(-3.0, 3.0)
            return rng.uniform(-100.0, 20.0)
        return rng.uniform(-180.0, 360.0)

    # first motion block: all five axes, A0 C0
    first = {ax: rand_axis(ax) for ax in "XYZ"}
    first["Z"] = abs(first["Z"]) + 20.0
    words = " ".join(f"{ax}{num(first[ax], 4)}" for ax in "XYZ")
    nline(f"G0 {words} A0 C0")
    q.update({ax: float(num(first[ax], 4)) for ax in "XYZ"})
    mode = 0
    after_length = False
    for _ in range(blocks - 1):
        r = rng.random()
        if r < 0.05:
            nline(rng.choice(["M8", "M9", "S1200 M3", "(A COMMENT ONLY)", "G4 P0.5", "M1"]))
            continue
        if r < 0.08:
            out.append(f"({rng.choice(['NEXT FEATURE', 'ROUGHING', 'FINISH PASS'])})")
            continue
        if hnums and r < 0.10:
            h = rng.choice(hnums)
            nline(f"G43 H{h}" if rng.random() < 0.8 else "G49")
            # A length change at rest moves the nominal tip: a post positions the tool
            # with a rapid before it cuts again (nccomp refuses a feed move from there).
            after_length = True
            continue
        k = rng.randint(1, 5)
        axes = rng.sample("XYZAC", k)
        parts = []
        if after_length:
            mode = 0
            parts.append("G0")
            after_length = False
        elif rng.random() < 0.3 or mode == 0 and rng.random() < 0.5:
            mode = 1 - mode if rng.random() < 0.6 else mode
            parts.append(f"G{mode}")
        for ax in "XYZAC":
            if ax not in axes:
                continue
            dec = rng.choice([3, 4])
            v = rand_axis(ax)
            text = num(v, dec)
            if float(text) == q[ax]:
                continue
            q[ax] = float(text)
            parts.append(f"{ax}{text}")
        if mode == 1 and rng.random() < 0.2:
            parts.append(f"F{rng.choice([500, 800, 1200, 2000])}")
        line = " ".join(parts)
        if rng.random() < 0.1:
            line += rng.choice([" (MOVE)", " ; trailing comment"])
        if not line.strip():
            line = "M9"
        nline(line)
    nline("M5")
    nline("M30")
    out.append("%")
    return "\n".join(out) + "\n"


def generate(seed, out_dir, blocks=500, only=None):
    # Separate streams: with --only, the machine and the program stay those of the seed.
    os.makedirs(out_dir, exist_ok=True)
    machine, hnums, a_offset = gen_machine(random.Random(f"machine {seed}"))
    errors = gen_errors(random.Random(f"errors {seed}"), only, a_offset)
    program = gen_program(random.Random(f"program {seed}"), blocks, hnums, seed)
    paths = {}
    for name, text in (("machine.toml", machine), ("errors.toml", errors),
                       ("program.nc", program)):
        p = os.path.join(out_dir, name)
        with open(p, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        paths[name] = p
    return paths


def cmd_generate(args):
    paths = generate(args.seed, args.out_dir, args.blocks, args.only)
    for p in paths.values():
        print(p)
    return 0


# --------------------------------------------------------------------------------------
# roundtrip
# --------------------------------------------------------------------------------------


def parse_seeds(text):
    seeds = []
    for part in text.split(","):
        part = part.strip()
        if "-" in part[1:]:
            a, b = part.split("-", 1)
            seeds.extend(range(int(a), int(b) + 1))
        elif part:
            seeds.append(int(part))
    return seeds


def cmd_roundtrip(args):
    seeds = parse_seeds(args.seeds)
    failed = []
    worst = {"tip": 0.0, "dir": 0.0, "sing_tip": 0.0, "swing": 0.0}
    with tempfile.TemporaryDirectory(prefix="nccomp-checker-") as tmp:
        for seed in seeds:
            d = os.path.join(tmp, f"seed{seed}")
            paths = generate(seed, d, args.blocks, args.only)
            out = os.path.join(d, "out.nc")
            cmd = [args.nccomp, "compensate", "--machine", paths["machine.toml"],
                   "--errors", paths["errors.toml"], paths["program.nc"], "-o", out,
                   *args.nccomp_arg]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                print(f"seed {seed}: FAIL nccomp exited {proc.returncode}: "
                      f"{proc.stderr.strip()[:2000]}")
                failed.append(seed)
                continue
            try:
                s = evaluate(paths["machine.toml"], paths["errors.toml"], paths["program.nc"],
                             out, tol_path_um=args.path_tol if args.path_tol > 0 else None)
            except (ModelError, ProgramError, ValueError) as e:
                print(f"seed {seed}: FAIL checker could not evaluate: {e}")
                failed.append(seed)
                continue
            if args.one_to_one and s["lines_in"] != s["lines_out"]:
                s["failures"].append(f"expected one output line per input line: input "
                                     f"{s['lines_in']}, output {s['lines_out']}")
                s["pass"] = False
            worst["tip"] = max(worst["tip"], s["max_tip_um"])
            worst["dir"] = max(worst["dir"], s["max_dir_urad"])
            worst["sing_tip"] = max(worst["sing_tip"], s["singular_max_tip_um"])
            worst["swing"] = max(worst["swing"], s["singular_max_swing_deg"])
            verdict = "PASS" if s["pass"] else "FAIL"
            print(f"seed {seed}: {verdict} {s['blocks_checked']} poses; "
                  f"uncompensated {s['uncompensated_max_tip_um']:.2f} um "
                  f"{s['uncompensated_max_dir_urad']:.1f} urad -> residual "
                  f"{s['max_tip_um']:.4f} um (line {_ln(s['max_tip_line'])}) "
                  f"{s['max_dir_urad']:.4f} urad (line {_ln(s['max_dir_line'])}); "
                  f"{s['singular']} singular: {s['singular_max_tip_um']:.4f} um, "
                  f"swing {s['singular_max_swing_deg']:.3g} deg; path "
                  f"{s['path_max_um']:.3f} um ({s['inserted_blocks']} blocks inserted, "
                  f"uncompensated {s['uncompensated_path_max_um']:.1f} um)")
            for f in s["failures"]:
                print(f"    {f}")
            if not s["pass"]:
                failed.append(seed)
                if args.keep:
                    keep = os.path.join(args.keep, f"seed{seed}")
                    os.makedirs(keep, exist_ok=True)
                    for name in ("machine.toml", "errors.toml", "program.nc", "out.nc"):
                        with open(os.path.join(d, name), "rb") as src, \
                                open(os.path.join(keep, name), "wb") as dst:
                            dst.write(src.read())
    print(f"overall: {len(seeds) - len(failed)}/{len(seeds)} seeds pass; worst residual "
          f"{worst['tip']:.4f} um, {worst['dir']:.4f} urad; singular {worst['sing_tip']:.4f} um, "
          f"swing {worst['swing']:.3g} deg")
    listed = ", ".join(map(str, failed))
    print(f"verdict: {'PASS' if not failed else 'FAIL (seeds ' + listed + ')'}")
    return 1 if failed else 0


# --------------------------------------------------------------------------------------


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)

    e = sub.add_parser("evaluate", help="check a compensated program against its input")
    e.add_argument("--machine", required=True)
    e.add_argument("--errors", required=True)
    e.add_argument("--input", required=True, help="the nominal program")
    e.add_argument("--output", required=True, help="the compensated program")
    e.add_argument("--tool-chain", default=None)
    e.add_argument("--json", action="store_true", help="print the summary as JSON")
    e.add_argument("-v", "--verbose", action="store_true", help="residuals of every pose")
    e.add_argument("--tip-tol", type=float, default=TOL_TIP_UM, help="um (default 1)")
    e.add_argument("--dir-tol", type=float, default=TOL_DIR_URAD, help="urad (default 10)")
    e.add_argument("--swing-tol", type=float, default=TOL_SWING_DEG,
                   help="deg (default 0.001)")
    e.add_argument("--path-tol", type=float, default=None,
                   help="um: fail when the middle of a compensated G1 move deviates more "
                        "(default: the path deviation is only reported)")
    e.set_defaults(func=cmd_evaluate)

    g = sub.add_parser("generate", help="write a random AC trunnion case")
    g.add_argument("--seed", type=int, required=True)
    g.add_argument("--out-dir", required=True)
    g.add_argument("--blocks", type=int, default=500)
    g.add_argument("--only", default=None,
                   help="only this error term (EXX, EC0Y, EX0C, ...), motion.AXIS, or none")
    g.set_defaults(func=cmd_generate)

    r = sub.add_parser("roundtrip", help="generate, compensate with nccomp, evaluate")
    r.add_argument("--seeds", default="1-20", help="e.g. 1-20 or 1,5,7-9")
    r.add_argument("--nccomp", required=True, help="path to the nccomp binary")
    r.add_argument("--blocks", type=int, default=500)
    r.add_argument("--only", default=None, help="as for generate")
    r.add_argument("--keep", default=None, help="copy failing cases into this directory")
    r.add_argument("--path-tol", type=float, default=1.5,
                   help="um: fail when a quarter point of a compensated G1 segment is further "
                        "from the nominal path (default 1.5; 0 or less: only report)")
    r.add_argument("--one-to-one", action="store_true",
                   help="fail when the output has more lines than the input")
    r.add_argument("--nccomp-arg", action="append", default=[],
                   help="an extra argument for nccomp compensate (repeatable), "
                        "e.g. --nccomp-arg=--tolerance=off")
    r.set_defaults(func=cmd_roundtrip)

    args = ap.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
