"""Write and run a CalculiX (ccx 2.20) deck: 2D plane-stress three-point bend of a strip.

Half model (symmetry at mid-span, x = 0), units mm, N, MPa. The strip has height
h (y from -h/2 to h/2) and out-of-plane thickness b; rollers and nose are
annular sectors of stiff elastic material (E_roll) with frictionless
surface-to-surface penalty contact (*CONTACT PAIR, *SURFACE BEHAVIOR
PRESSURE-OVERCLOSURE=LINEAR). The support's inner arc is fixed; the nose's inner
arc moves down by d (NLGEOM, *STATIC). A very soft SPRING1 element (1e-6 of
the bend stiffness) holds the strip vertically before the contacts close.

Only numpy and the ``ccx`` executable are needed. The deck is written to a
scratch folder (not committed); :func:`run` parses the .dat file.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np


@dataclass
class Params:
    S: float = 8.0  # span
    h: float = 2.4  # strip height (= tube outer diameter: same contact geometry as the rod model)
    EI: float = 65.345  # N mm^2, the tube's E_b (tube3d README)
    E: float = 50.0
    nu: float = 0.45
    overhang: float = 4.0
    Rs: float = 2.0
    Rn: float = 2.0
    E_roll: float = 1.0e5
    ring: float = 0.6  # radial thickness of the roller/nose sector
    K: float = 1.0e5  # penalty slope, MPa/mm
    level: float = 1.0  # mesh refinement factor
    fine: float = 0.06  # element length in contact zones (divided by level)
    coarse: float = 0.3
    ny: int = 8  # elements through the height (times level)
    d_over_S: float = 0.15
    dtmax: float = 1.0 / 60.0
    dt0: float = 1.0 / 240.0
    etype: str = "CPS8"

    @property
    def b(self) -> float:
        """Out-of-plane thickness giving the strip the tube's bending stiffness EI."""
        return 12.0 * self.EI / (self.E * self.h**3)


def _graded(breaks: list[float], sizes: list[float]) -> np.ndarray:
    """Corner coordinates: segment i from breaks[i] to breaks[i+1] with element size ~sizes[i]."""
    out = [breaks[0]]
    for a, b, s in zip(breaks[:-1], breaks[1:], sizes, strict=True):
        n = max(1, int(np.ceil((b - a) / s - 1e-9)))
        out.extend(np.linspace(a, b, n + 1)[1:])
    return np.array(out)


class Mesh:
    """Quadratic quads (8 nodes) on mapped structured grids; nodes numbered globally."""

    def __init__(self):
        self.nodes: list[tuple[float, float]] = []
        self.elements: dict[str, list[list[int]]] = {}

    def block(self, name: str, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Add a block from (2nu+1, 2nv+1) node grids X, Y (ccw in (u, v)); returns the id grid."""
        nu, nv = (X.shape[0] - 1) // 2, (X.shape[1] - 1) // 2
        ids = np.zeros(X.shape, int)
        for i in range(X.shape[0]):
            for j in range(X.shape[1]):
                if i % 2 and j % 2:
                    continue  # no centre node for 8-node elements
                self.nodes.append((float(X[i, j]), float(Y[i, j])))
                ids[i, j] = len(self.nodes)
        els = []
        for a in range(nu):
            for c in range(nv):
                i, j = 2 * a, 2 * c
                els.append(
                    [
                        ids[i, j], ids[i + 2, j], ids[i + 2, j + 2], ids[i, j + 2],
                        ids[i + 1, j], ids[i + 2, j + 1], ids[i + 1, j + 2], ids[i, j + 1],
                    ]
                )  # fmt: skip
        self.elements[name] = els
        return ids


def _refine(c: np.ndarray) -> np.ndarray:
    """Corner coordinates -> corner and mid-side coordinates."""
    out = np.empty(2 * len(c) - 1)
    out[::2] = c
    out[1::2] = 0.5 * (c[:-1] + c[1:])
    return out


def build(p: Params) -> tuple[Mesh, dict]:
    lv = p.level
    f, co = p.fine / lv, p.coarse / lv
    xs, L = 0.5 * p.S, 0.5 * p.S + p.overhang
    breaks = [0.0, 1.5, xs - 1.6, xs, xs + 0.8, L]
    sizes = [f, co, f, f, co]
    if xs - 1.6 <= 1.5:
        breaks, sizes = [0.0, xs, xs + 0.8, L], [f, f, co]
    xc = _refine(_graded(breaks, sizes))
    yc = _refine(np.linspace(-p.h / 2, p.h / 2, int(round(p.ny * lv)) + 1))
    m = Mesh()
    X, Y = np.meshgrid(xc, yc, indexing="ij")
    strip = m.block("STRIP", X, Y)
    # support sector: centre (xs, -h/2 - Rs), angles 50..150 deg (contact moves inward as it rotates)
    ca, cb = np.deg2rad(50.0), np.deg2rad(150.0)
    na = int(np.ceil((cb - ca) * p.Rs / (0.8 * f)))
    nr = max(2, int(round(2 * lv)))
    r = _refine(np.linspace(p.Rs - p.ring, p.Rs, nr + 1))
    th = _refine(np.linspace(ca, cb, na + 1))
    R, T = np.meshgrid(r, th, indexing="ij")
    sup = m.block("SUP", xs + R * np.cos(T), -p.h / 2 - p.Rs + R * np.sin(T))
    # nose sector: centre (0, h/2 + Rn), angles 270..325 deg (x >= 0)
    ca, cb = np.deg2rad(270.0), np.deg2rad(325.0)
    na = int(np.ceil((cb - ca) * p.Rn / (0.8 * f)))
    r = _refine(np.linspace(p.Rn - p.ring, p.Rn, nr + 1))
    th = _refine(np.linspace(ca, cb, na + 1))
    R, T = np.meshgrid(r, th, indexing="ij")
    nose = m.block("NOSE", R * np.cos(T), p.h / 2 + p.Rn + R * np.sin(T))
    iy0 = (strip.shape[1] - 1) // 2
    ix_s = int(np.argmin(np.abs(xc - xs)))
    assert abs(xc[ix_s] - xs) < 1e-12
    sets = {
        "SYM": np.concatenate([strip[0, :], nose[:, 0]]),
        "SUPFIX": sup[0, :],
        "NOSEDRV": nose[0, :],
        "MID": strip[0, iy0 : iy0 + 1],
        "SUPSEC": strip[ix_s, :],  # the whole support cross-section (its centre is iy0)
        "CL": strip[::2, iy0],  # centreline corners
    }
    sets["SUPSEC_C"] = strip[ix_s, iy0 : iy0 + 1]
    info = {"xc": xc, "strip": strip, "iy0": iy0, "ix_s": ix_s}
    return m, sets | {"_info": info}


def _face_elems(m: Mesh, name: str, first: int, pick) -> list[int]:
    """Element numbers of block ``name`` (numbered from ``first``) for which pick(index) holds."""
    return [first + k for k in range(len(m.elements[name])) if pick(k)]


def write_deck(p: Params, path: Path) -> dict:
    m, sets = build(p)
    info = sets.pop("_info")
    nye = (info["strip"].shape[1] - 1) // 2
    lines = ["*HEADING", f"three-point bend, plane stress strip {asdict(p)}", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.10g}, {y:.10g}, 0" for i, (x, y) in enumerate(m.nodes)]
    first, eid = {}, 0
    for name, els in m.elements.items():
        first[name] = eid + 1
        lines.append(f"*ELEMENT, TYPE={p.etype}, ELSET={name}")
        for e in els:
            eid += 1
            lines.append(", ".join(str(v) for v in [eid, *e]))
    # SPRING1 elements: soft vertical springs at the strip's mid-span centre node
    k_soft = 1e-6 * 48 * p.EI / p.S**3
    lines += ["*ELEMENT, TYPE=SPRING1, ELSET=ESPR", f"{eid + 1}, {int(sets['MID'][0])}"]
    lines += ["*SPRING, ELSET=ESPR", "2", f"{k_soft:.6g}"]
    for name, ids in sets.items():
        lines.append(f"*NSET, NSET={name}")
        ids = [int(v) for v in np.ravel(ids)]
        lines += [", ".join(map(str, ids[k : k + 12])) for k in range(0, len(ids), 12)]
    # contact faces: strip elements are numbered x-major (a * nye + c)
    top = _face_elems(m, "STRIP", first["STRIP"], lambda k: k % nye == nye - 1)
    bot = _face_elems(m, "STRIP", first["STRIP"], lambda k: k % nye == 0)
    xe = info["xc"][::2]
    xs = 0.5 * p.S
    top = [e for e in top if xe[(e - first["STRIP"]) // nye] < 2.5]
    bot = [e for e in bot if xs - 2.5 < xe[(e - first["STRIP"]) // nye] < xs + 1.5]
    nre = {k: len(m.elements[k]) for k in ("SUP", "NOSE")}
    nr = max(2, int(round(2 * p.level)))
    outer = {k: [first[k] + i for i in range(nre[k]) if i // (nre[k] // nr) == nr - 1] for k in nre}
    lines += ["*SURFACE, NAME=STOP, TYPE=ELEMENT"] + [f"{e}, S3" for e in top]
    lines += ["*SURFACE, NAME=SBOT, TYPE=ELEMENT"] + [f"{e}, S1" for e in bot]
    lines += ["*SURFACE, NAME=MSUP, TYPE=ELEMENT"] + [f"{e}, S2" for e in outer["SUP"]]
    lines += ["*SURFACE, NAME=MNOSE, TYPE=ELEMENT"] + [f"{e}, S2" for e in outer["NOSE"]]
    lines += [
        "*MATERIAL, NAME=TUBE", "*ELASTIC", f"{p.E}, {p.nu}",
        "*MATERIAL, NAME=ROLL", "*ELASTIC", f"{p.E_roll}, 0.3",
        "*SOLID SECTION, ELSET=STRIP, MATERIAL=TUBE", f"{p.b:.10g}",
        "*SOLID SECTION, ELSET=SUP, MATERIAL=ROLL", f"{p.b:.10g}",
        "*SOLID SECTION, ELSET=NOSE, MATERIAL=ROLL", f"{p.b:.10g}",
        "*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{p.K:g}",
        "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE", "STOP, MNOSE",
        "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE", "SBOT, MSUP",
        "*BOUNDARY", "SYM, 1, 1", "SUPFIX, 1, 2", "NOSEDRV, 1, 1",
        "*STEP, NLGEOM, INC=10000",
        "*STATIC", f"{p.dt0:g}, 1.0, 1e-7, {p.dtmax:g}",
        "*BOUNDARY", f"NOSEDRV, 2, 2, {-p.d_over_S * p.S:.10g}",
        "*NODE PRINT, NSET=NOSEDRV, TOTALS=ONLY", "RF",
        "*NODE PRINT, NSET=SUPFIX, TOTALS=ONLY", "RF",
        "*NODE PRINT, NSET=MID", "U",
        "*NODE PRINT, NSET=SUPSEC_C", "U",
        "*NODE PRINT, NSET=CL", "U",
        "*NODE PRINT, NSET=SUPSEC", "U",
        "*END STEP",
    ]  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    strip = info["strip"]
    cl_xy = [m.nodes[i - 1] for i in np.ravel(sets["CL"])]
    sec_xy = [m.nodes[i - 1] for i in np.ravel(sets["SUPSEC"])]
    return {
        "nodes": len(m.nodes),
        "elements": eid,
        "_cl": np.array(cl_xy),
        "_sec": np.array(sec_xy),
        "_ix": info["ix_s"] // 2,
        "_strip_shape": strip.shape,
    }


_HEAD = re.compile(r"^\s*(.+?) \(.*\) for set (\S+) and time\s+(\S+)")


def parse_dat(path: Path) -> dict[tuple[str, float], dict[str, np.ndarray]]:
    """{time: {set/kind: rows}} from a ccx .dat file (node rows: [id, v1, v2, v3]; totals: [v1..])."""
    out: dict = {}
    key = None
    for line in path.read_text().splitlines():
        mt = _HEAD.match(line)
        if mt:
            kind, name, t = mt.group(1).strip(), mt.group(2), float(mt.group(3))
            key = (t, f"{name}:{'total' if kind.startswith('total') else kind}")
            out.setdefault(key[0], {})[key[1]] = []
            continue
        parts = line.split()
        if key and parts:
            try:
                out[key[0]][key[1]].append([float(v) for v in parts])
            except ValueError:
                key = None
    return {t: {k: np.array(v) for k, v in d.items()} for t, d in sorted(out.items())}


def run(p: Params, work: Path, threads: int = 2, nice: int = 10) -> dict:
    """Write the deck in ``work``, run ccx, return the per-increment results (mm, N, rad)."""
    work.mkdir(parents=True, exist_ok=True)
    meta = write_deck(p, work / "bend.inp")
    n = str(threads)
    env = {"OMP_NUM_THREADS": n, "CCX_NPROC_EQUATION_SOLVER": n, "PATH": "/usr/bin:/bin"}
    proc = subprocess.run(
        ["nice", "-n", str(nice), "ccx", "-i", "bend"], cwd=work, env=env, capture_output=True, text=True
    )
    (work / "ccx.log").write_text(proc.stdout + proc.stderr)
    res = parse_dat(work / "bend.dat") if (work / "bend.dat").exists() else {}
    rows = []
    for t, d in res.items():
        try:
            Fn = d["NOSEDRV:total"][0]
            Rs = d["SUPFIX:total"][0]
            um = d["MID:displacements"][0][1:]
            us = d["SUPSEC_C:displacements"][0][1:]
            cl = d["CL:displacements"]
            sec = d["SUPSEC:displacements"]
        except (KeyError, IndexError):
            continue
        ang = _angles(meta, cl, sec)
        rows.append(
            {
                "t": t,
                "delta": t * p.d_over_S * p.S,
                "F": -2.0 * Fn[1],  # whole strip: twice the half model's nose reaction
                "Vs": Rs[1],  # support reaction on the support roller (fixed arc), half model
                "Hs": Rs[0],
                "angle": float(np.arctan2(-Rs[0], Rs[1])),  # tilt of the support force from vertical
                "uy_mid": um[1],
                "uy_sup": us[1],
                "ux_sup": us[0],
                "delta_centroid": us[1] - um[1],
            }
            | ang
        )
    meta = {k: v for k, v in meta.items() if not k.startswith("_")}
    return {"params": asdict(p) | {"b": p.b}, **meta, "ccx_rc": proc.returncode, "rows": rows}


def _angles(meta: dict, cl: np.ndarray, sec: np.ndarray) -> dict:
    """Deformed-geometry angles at the support section (rad, positive = the natural rotation).

    psi_in / psi_out: centreline tangent on the span side / overhang side (second-order
    one-sided differences of the deformed corner nodes); theta_sec: tilt from vertical of the
    deformed support cross-section (least-squares line through its nodes).
    """
    X = meta["_cl"] + cl[:, 1:3]
    i = meta["_ix"]

    t_in = 3 * X[i] - 4 * X[i - 1] + X[i - 2]  # backward difference: d(position)/dX at the support
    t_out = -3 * X[i] + 4 * X[i + 1] - X[i + 2]  # forward difference
    S = meta["_sec"] + sec[:, 1:3]
    slope = np.polyfit(S[:, 1], S[:, 0], 1)[0]  # dx/dy along the section
    return {
        "psi_in": float(np.arctan2(t_in[1], t_in[0])),
        "psi_out": float(np.arctan2(t_out[1], t_out[0])),
        "theta_sec": float(-np.arctan(slope)),
    }
