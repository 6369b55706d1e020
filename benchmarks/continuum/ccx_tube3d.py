"""Write and run a CalculiX deck: 3D quarter model of a tube in the three-point-bend rig.

x along the tube axis (x = 0 mid-span, symmetry ux = 0), y up, z across
(z = 0 symmetry plane through the tube axis, uz = 0). C3D20 (or C3D20R) hexahedra
on mapped structured blocks: the tube wall in (x, r, phi), phi = 0 at the top,
pi at the bottom; support roller and nose are annular sectors of stiff elastic
material extruded along z (axis along z), with frictionless surface-to-surface
penalty contact. The support's inner face is fixed, the nose's inner face moves
down by d. NLGEOM. Units mm, N, MPa.

The centreline displacement of a section is the area-weighted mean of its
nodes' vertical displacement (tributary weights r dr dphi). Whole-tube nose
force = 4 x the quarter model's.
"""

from __future__ import annotations

import subprocess
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from ccx_deck import _graded, _refine, parse_dat


@dataclass
class TubeParams:
    S: float = 8.0
    Ro: float = 1.2
    Ri: float = 0.8
    E: float = 50.0
    nu: float = 0.45
    Rs: float = 2.0
    Rn: float = 2.0
    overhang: float = 4.0
    E_roll: float = 1.0e5
    K: float = 1.0e5
    ring: float = 0.6
    xw: float = 1.6  # roller half length along z
    roll_dx: float = 0.0  # roller element size along its arc (0: 0.7 x the fine size)
    roll_dz: float = 0.0  # roller element size along its axis (0: 4 elements over xw)
    rs_a: tuple = (60.0, 120.0)  # support roller sector (deg from +x about its centre)
    nose_a: float = 40.0  # nose sector from the bottom point towards +x (deg)
    profile: bool = False  # also print every tube node: the section-mean deflection along the span
    phi_grade: float = 0.6  # grading of the circumferential grid towards top and bottom (0: uniform)
    level: float = 1.0
    ax: float = 1.0  # extra refinement along the axis (element sizes / ax)
    wall: float = 1.0  # extra refinement through the wall (nr * wall)
    circ: float = 1.0  # extra refinement round the circumference (nphi * circ)
    fine: float = 0.15
    coarse: float = 0.6
    nr: int = 2
    nphi: int = 12  # elements over the half circumference
    fractions: tuple = (0.0025, 0.005, 0.01)
    etype: str = "C3D20"
    slave: str = "tube"  # slave side of the contact pairs: "tube" or "rollers"


# (xi, eta, zeta) of the 20 C3D20 nodes, ccx order
_LOCAL = [
    (-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1),
    (0, -1, -1), (1, 0, -1), (0, 1, -1), (-1, 0, -1), (0, -1, 1), (1, 0, 1), (0, 1, 1), (-1, 0, 1),
    (-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0),
]  # fmt: skip


class Mesh3:
    def __init__(self):
        self.nodes: list[tuple[float, float, float]] = []
        self.blocks: dict[str, list[list[int]]] = {}

    def block(self, name, P: np.ndarray) -> np.ndarray:
        """P: (2a+1, 2b+1, 2c+1, 3) node grid, right-handed in (u, v, w). Returns the id grid."""
        shape = P.shape[:3]
        ids = np.zeros(shape, int)
        for i in range(shape[0]):
            for j in range(shape[1]):
                for k in range(shape[2]):
                    if (i % 2) + (j % 2) + (k % 2) >= 2:
                        continue  # face and body centres are not C3D20 nodes
                    self.nodes.append(tuple(float(v) for v in P[i, j, k]))
                    ids[i, j, k] = len(self.nodes)
        els = []
        for a in range(shape[0] // 2):
            for b in range(shape[1] // 2):
                for c in range(shape[2] // 2):
                    els.append([int(ids[2 * a + 1 + u, 2 * b + 1 + v, 2 * c + 1 + w]) for u, v, w in _LOCAL])
        self.blocks[name] = els
        return ids


def _phi_grid(n: int, grade: float = 0.6) -> np.ndarray:
    """Corner angles 0..pi, finer at the top and bottom (the contacts) by ``grade`` (0: uniform)."""
    s = np.linspace(0.0, 1.0, n + 1)
    return np.pi * (s - np.sin(2 * np.pi * s) / (2 * np.pi) * grade)


def build(p: TubeParams):
    lv = p.level
    f, co = p.fine / (lv * p.ax), p.coarse / (lv * p.ax)
    xs, L = 0.5 * p.S, 0.5 * p.S + p.overhang
    if xs - 1.5 > 1.2:
        breaks, sizes = [0.0, 1.2, xs - 1.5, xs, xs + 1.5, L], [f, co, f, f, co]
    else:
        breaks, sizes = [0.0, xs, xs + 1.5, L], [f, f, co]
    xc = _refine(_graded(breaks, sizes))
    rc = _refine(np.linspace(p.Ri, p.Ro, int(round(p.nr * lv * p.wall)) + 1))
    pc = _refine(_phi_grid(int(round(p.nphi * lv * p.circ)), p.phi_grade))
    X, R, PH = np.meshgrid(xc, rc, pc, indexing="ij")
    m = Mesh3()
    tube = m.block("TUBE", np.stack([X, R * np.cos(PH), R * np.sin(PH)], -1))
    nz = int(np.ceil(p.xw / p.roll_dz - 1e-9)) if p.roll_dz else max(2, int(round(4 * lv)))
    zc = _refine(np.linspace(0.0, p.xw, nz + 1))
    nrr = max(2, int(round(2 * lv)))
    blocks = {}
    for name, (cx, cy, a0, a1, rad) in {
        "SUP": (xs, -p.Ro - p.Rs, p.rs_a[0], p.rs_a[1], p.Rs),
        "NOSE": (0.0, p.Ro + p.Rn, 270.0, 270.0 + p.nose_a, p.Rn),
    }.items():
        th0, th1 = np.deg2rad(a0), np.deg2rad(a1)
        nth = int(np.ceil((th1 - th0) * rad / (p.roll_dx or 0.7 * f)))
        rr = _refine(np.linspace(rad - p.ring, rad, nrr + 1))
        tt = _refine(np.linspace(th0, th1, nth + 1))
        RR, TT, ZZ = np.meshgrid(rr, tt, zc, indexing="ij")
        blocks[name] = m.block(name, np.stack([cx + RR * np.cos(TT), cy + RR * np.sin(TT), ZZ], -1))
    return m, tube, blocks, xc, rc, pc


def _weights(rc: np.ndarray, pc: np.ndarray) -> np.ndarray:
    """Tributary area weights r dr dphi on the (r, phi) node grid of a section."""

    def trib(v):
        w = np.zeros_like(v)
        d = np.diff(v)
        w[:-1] += d / 2
        w[1:] += d / 2
        return w

    return rc[:, None] * trib(rc)[:, None] * trib(pc)[None, :]


def write_deck(p: TubeParams, path: Path) -> dict:
    m, tube, blocks, xc, rc, pc = build(p)
    xs = 0.5 * p.S
    ix_s = int(np.argmin(np.abs(xc - xs)))
    assert abs(xc[ix_s] - xs) < 1e-12
    lines = ["*HEADING", f"tube three-point bend {asdict(p)}", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.10g}, {y:.10g}, {z:.10g}" for i, (x, y, z) in enumerate(m.nodes)]
    first, eid = {}, 0
    for name, els in m.blocks.items():
        first[name] = eid + 1
        lines.append(f"*ELEMENT, TYPE={p.etype}, ELSET={name}")
        for e in els:
            eid += 1
            v = [str(x) for x in [eid, *e]]
            lines += [", ".join(v[:16]) + ",", ", ".join(v[16:])]  # ccx: at most 16 entries a line
    sec_ok = tube[0] > 0
    mid_sec = tube[0][sec_ok]
    sup_sec = tube[ix_s][sec_ok]
    w = _weights(rc, pc)[sec_ok]
    spring_node = int(tube[0, -1, -1])  # mid-span, bottom outer
    k_soft = 1e-6 * 48 * 6.5e1 / p.S**3
    lines += ["*ELEMENT, TYPE=SPRING1, ELSET=ESPR", f"{eid + 1}, {spring_node}"]
    lines += ["*SPRING, ELSET=ESPR", "2", f"{k_soft:.6g}"]
    sets = {
        "XSYM": tube[0][sec_ok],
        "ZSYM": np.concatenate([tube[:, :, 0].ravel(), tube[:, :, -1].ravel()]),
        "SUPFIX": blocks["SUP"][0].ravel(),
        "NOSEDRV": blocks["NOSE"][0].ravel(),
        "RZSYM": np.concatenate([blocks["SUP"][:, :, 0].ravel(), blocks["NOSE"][:, :, 0].ravel()]),
        "MIDSEC": mid_sec,
        "SUPSEC": sup_sec,
    }
    if p.profile:
        sets["TUBEN"] = tube[tube > 0]
    for name, ids in sets.items():
        ids = [int(v) for v in np.ravel(ids) if v > 0]
        lines.append(f"*NSET, NSET={name}")
        lines += [", ".join(map(str, ids[k : k + 12])) for k in range(0, len(ids), 12)]
    # tube elements are numbered (a x, b r, c phi); outer r layer, face S5 (eta = +1)
    na, nb, nc = (np.array(tube.shape) - 1) // 2
    xe = xc[::2]
    pe = pc[::2]
    top, bot = [], []
    for a in range(na):
        for c in range(nc):
            e = first["TUBE"] + (a * nb + (nb - 1)) * nc + c
            if pe[c] < np.pi / 2 and xe[a] < 1.5:
                top.append(e)
            if pe[c + 1] > np.pi / 2 and abs(xe[a] - xs) < 1.5 + 1e-9:
                bot.append(e)
    outer = {}
    for k in ("SUP", "NOSE"):
        ra, tb, zc_ = (np.array(blocks[k].shape) - 1) // 2
        outer[k] = [first[k] + ((ra - 1) * tb + b) * zc_ + c for b in range(tb) for c in range(zc_)]
    lines += ["*SURFACE, NAME=STOP, TYPE=ELEMENT"] + [f"{e}, S5" for e in top]
    lines += ["*SURFACE, NAME=SBOT, TYPE=ELEMENT"] + [f"{e}, S5" for e in bot]
    lines += ["*SURFACE, NAME=MSUP, TYPE=ELEMENT"] + [f"{e}, S4" for e in outer["SUP"]]
    lines += ["*SURFACE, NAME=MNOSE, TYPE=ELEMENT"] + [f"{e}, S4" for e in outer["NOSE"]]
    pairs = ("STOP, MNOSE", "SBOT, MSUP") if p.slave == "tube" else ("MNOSE, STOP", "MSUP, SBOT")
    steps = list(p.fractions)
    dmax = steps[-1] * p.S
    dt = steps[0] / steps[-1]
    lines += [
        "*MATERIAL, NAME=TUBE", "*ELASTIC", f"{p.E}, {p.nu}",
        "*MATERIAL, NAME=ROLL", "*ELASTIC", f"{p.E_roll}, 0.3",
        "*SOLID SECTION, ELSET=TUBE, MATERIAL=TUBE",
        "*SOLID SECTION, ELSET=SUP, MATERIAL=ROLL",
        "*SOLID SECTION, ELSET=NOSE, MATERIAL=ROLL",
        "*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{p.K:g}",
        "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE", pairs[0],
        "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE", pairs[1],
        "*BOUNDARY", "XSYM, 1, 1", "ZSYM, 3, 3", "SUPFIX, 1, 3", "NOSEDRV, 1, 1", "NOSEDRV, 3, 3",
        "RZSYM, 3, 3",
        "*TIME POINTS, NAME=TP", ", ".join(f"{s / steps[-1]:.6g}" for s in steps),
        "*STEP, NLGEOM, INC=1000",
        "*STATIC", f"{dt:g}, 1.0, 1e-6, {dt:g}",
        "*BOUNDARY", f"NOSEDRV, 2, 2, {-dmax:.10g}",
        "*NODE PRINT, NSET=NOSEDRV, TOTALS=ONLY, TIME POINTS=TP", "RF",
        "*NODE PRINT, NSET=SUPFIX, TOTALS=ONLY, TIME POINTS=TP", "RF",
        "*NODE PRINT, NSET=MIDSEC, TIME POINTS=TP", "U",
        "*NODE PRINT, NSET=SUPSEC, TIME POINTS=TP", "U",
        *(["*NODE PRINT, NSET=TUBEN, TIME POINTS=TP", "U"] if p.profile else []),
        "*END STEP",
    ]  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    order = {int(n): i for i, n in enumerate(np.ravel(mid_sec))}
    order_s = {int(n): i for i, n in enumerate(np.ravel(sup_sec))}
    out = {"nodes": len(m.nodes), "elements": eid, "_w": w, "_om": order, "_os": order_s, "_dmax": dmax}
    return out | {"_tube": tube, "_xc": xc, "_wsec": _weights(rc, pc)}


def _profile(rows: np.ndarray, tube: np.ndarray, xc: np.ndarray, wsec: np.ndarray) -> list[list[float]]:
    """[x, area-weighted mean uy] of every section at an element corner along the axis."""
    uy = {int(r[0]): r[2] for r in rows}
    out = []
    for i in range(0, len(xc), 2):
        ok = tube[i] > 0
        vals = np.array([uy[int(n)] for n in tube[i][ok]])
        out.append([float(xc[i]), float(np.sum(vals * wsec[ok]) / np.sum(wsec[ok]))])
    return out


def _mean_uy(rows: np.ndarray, order: dict, w: np.ndarray) -> float:
    uy = np.zeros(len(order))
    for r in rows:
        uy[order[int(r[0])]] = r[2]
    return float(np.sum(uy * w) / np.sum(w))


def run(p: TubeParams, work: Path, threads: int = 2, nice: int = 10) -> dict:
    work.mkdir(parents=True, exist_ok=True)
    meta = write_deck(p, work / "tube.inp")
    n = str(threads)
    env = {"OMP_NUM_THREADS": n, "CCX_NPROC_EQUATION_SOLVER": n, "PATH": "/usr/bin:/bin"}
    proc = subprocess.run(
        ["nice", "-n", str(nice), "ccx", "-i", "tube"], cwd=work, env=env, capture_output=True, text=True
    )
    (work / "ccx.log").write_text(proc.stdout + proc.stderr)
    res = parse_dat(work / "tube.dat") if (work / "tube.dat").exists() else {}
    w = meta["_w"].ravel()
    rows = []
    for t, d in res.items():
        try:
            Fn, Rs = d["NOSEDRV:total"][0], d["SUPFIX:total"][0]
            um = _mean_uy(d["MIDSEC:displacements"], meta["_om"], w)
            us = _mean_uy(d["SUPSEC:displacements"], meta["_os"], w)
        except (KeyError, IndexError):
            continue
        delta = t * meta["_dmax"]
        F = -4.0 * Fn[1]
        rows.append(
            {
                "t": t,
                "delta": delta,
                "F": F,
                "Vs": Rs[1],
                "Hs": Rs[0],
                "uy_mid": um,
                "uy_sup": us,
                "delta_centroid": us - um,
                "local_compliance": (delta - (us - um)) / F,
            }
        )
        if p.profile and "TUBEN:displacements" in d:
            rows[-1]["profile"] = _profile(
                d["TUBEN:displacements"], meta["_tube"], meta["_xc"], meta["_wsec"]
            )
    meta = {k: v for k, v in meta.items() if not k.startswith("_")}
    return {"params": asdict(p), **meta, "ccx_rc": proc.returncode, "rows": rows}
