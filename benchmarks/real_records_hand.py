"""Hand values for benchmarks/real_records.py: numpy only, independent of matid's code.

Each function reads the machine's file with plain line splitting (the header lines
to skip, the delimiter and the decimal mark are stated per record) and returns the
stiffness matid reports for the kind, in SI:

- extension: E_e = EA [N] (force per engineering strain),
- torsion: E_t = GJ [N m^2] (torque per twist per length),
- three-point bend: the flexural stiffness E_b,app = k S^3 / 48 [N m^2] from the
  initial slope k = dF/dd (bending and shear compliance together, no local terms).

Every slope is an ordinary least-squares line (slope and offset) over a window
stated in the record, so the numbers can be checked by hand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

IN = 0.0254  # m
LBF_IN = 4.4482216152605 * IN  # N m per in-lbf


def read_table(
    path: Path,
    skip: int,
    delim: str | None,
    *,
    decimal: str = ".",
    encoding: str = "utf-8-sig",
    first_cells: int | None = None,
):
    """Rows of numbers after ``skip`` lines; cells split on ``delim`` (None: whitespace), quotes dropped;
    only the ``first_cells`` cells of each row when given (a text column after them)."""
    rows = []
    with open(path, encoding=encoding, errors="replace") as fh:
        for i, line in enumerate(fh):
            if i < skip:
                continue
            line = line.strip().replace('"', "")
            if not line:
                continue
            cells = [c for c in (line.split(delim) if delim else line.split()) if c.strip()][:first_cells]
            if decimal == ",":
                cells = [c.replace(",", ".") for c in cells]
            try:
                rows.append([float(c) for c in cells])
            except ValueError:
                continue
    width = max(len(r) for r in rows)
    return np.array([r for r in rows if len(r) == width])


def line_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float, int]:
    """Least-squares slope, its standard error and the number of points of y = a x + b."""
    A = np.vstack([x, np.ones_like(x)]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ coef
    n = len(x)
    s2 = r @ r / max(n - 2, 1)
    cov = s2 * np.linalg.inv(A.T @ A)
    return float(coef[0]), float(np.sqrt(cov[0, 0])), n


def loading_window(x: np.ndarray, y: np.ndarray, lo: float, hi: float):
    """Loading-branch rows (start to the extreme of y) where |y - y0| lies in [lo, hi] of the excursion."""
    peak = int(np.argmax(np.abs(y - y[0])))
    xs, ys = x[: peak + 1], y[: peak + 1]
    rise = np.abs(ys - ys[0]) / abs(ys[-1] - ys[0])
    keep = (rise >= lo) & (rise <= hi)
    return xs[keep], ys[keep]


# --- torsion -----------------------------------------------------------------------


def torsion(path, *, skip, delim, angle_col, torque_col, length_m, lo=0.1, hi=0.8, torque_si=LBF_IN):
    """E_t = L dT/dphi over the loading rows between lo and hi of the torque excursion (angle in deg)."""
    a = read_table(path, skip, delim)
    phi = np.deg2rad(a[:, angle_col])
    T = a[:, torque_col] * torque_si
    x, y = loading_window(phi, T, lo, hi)
    k, se, n = line_fit(x, y)
    return abs(k) * length_m, se * length_m, n


# --- three-point bend --------------------------------------------------------------


def bend(path, *, skip, rows, span_m, defl_col=0, force_col=1, force_si=1e3, defl_si=1e-3):
    """E_b,app = S^3/48 dF/dd over the data rows ``rows`` = (first, last) (0-based, after the header)."""
    a = read_table(path, skip, None)
    d = a[rows[0] : rows[1], defl_col] * defl_si
    F = a[rows[0] : rows[1], force_col] * force_si
    k, se, n = line_fit(d, F)
    return abs(k) * span_m**3 / 48, se * span_m**3 / 48, n


# --- extension ---------------------------------------------------------------------


def extension_window(
    path,
    *,
    skip,
    delim,
    decimal,
    elong_col,
    force_col,
    gauge_m,
    window_m,
    force_si=1e3,
    elong_si=1e-3,
    encoding="utf-8-sig",
    strain_col=False,
    first_cells=None,
    until_s=None,
):
    """E_e = dF/d(strain) over the loading rows with elongation (or strain) inside ``window``: the
    rows up to the peak force, or with ``until_s`` up to that time (column 0, s: the first loading
    of load-unload cycles whose peaks grow)."""
    a = read_table(path, skip, delim, decimal=decimal, encoding=encoding, first_cells=first_cells)
    if until_s is not None:
        a = a[a[:, 0] <= until_s]
    peak = int(np.argmax(a[:, force_col]))
    x = a[: peak + 1, elong_col] * elong_si
    F = a[: peak + 1, force_col] * force_si
    keep = (x >= window_m[0]) & (x <= window_m[1])
    eps = x[keep] if strain_col else x[keep] / gauge_m
    k, se, n = line_fit(eps, F[keep])
    return k, se, n


def load_fraction_line(path, *, skip, delim, force_col, strain_col, force_si, strain_si, lo=0.1, hi=0.9):
    """E_e of load-unload cycles from rest: a least-squares line F(strain) over every row (loading,
    holds and unloading alike) whose force lies between ``lo`` and ``hi`` of the record's peak force.
    An elastic specimen (no hysteresis) gives the same slope on every branch."""
    a = read_table(path, skip, delim)
    F, eps = a[:, force_col] * force_si, a[:, strain_col] * strain_si
    keep = (F >= lo * F.max()) & (F <= hi * F.max())
    return line_fit(eps[keep], F[keep])


def relaxation(path, *, gauge_m, tail_s=60.0, encoding="gbk"):
    """E_e of a ramp-hold: the force at the end of the hold over the strain of the hold (the
    equilibrium spring k1 of the standard linear solid, reached when the relaxation is over; a
    record that still relaxes makes this an upper bound). Mean force and strain over the last
    ``tail_s`` seconds; standard error from their scatter. Columns: time (s), elongation (mm), force (N)."""
    a = read_table(path, 2, ",", encoding=encoding)
    t, u, F = a[:, 0], a[:, 1] * 1e-3, a[:, 2]
    tail = t >= t[-1] - tail_s
    eps = float(np.mean(u[tail])) / gauge_m
    return float(np.mean(F[tail])) / eps, float(np.std(F[tail]) / np.sqrt(tail.sum())) / eps, int(tail.sum())


def cycle_mean(path, *, gauge_m, strain_window, encoding="gbk"):
    """E_e of a load-unload cycle: the loading and unloading forces interpolated to common strains,
    averaged (the rate-dependent part changes sign between the branches), and a least-squares line of
    that mean against strain over ``strain_window``. Columns: time (s), elongation (mm), force (N)."""
    a = read_table(path, 2, ",", encoding=encoding)
    u, F = a[:, 1] * 1e-3, a[:, 2]
    top = int(np.argmax(u))
    eps_up, F_up = u[: top + 1] / gauge_m, F[: top + 1]
    eps_dn, F_dn = u[top:][::-1] / gauge_m, F[top:][::-1]
    grid = np.linspace(strain_window[0], strain_window[1], 200)
    up = np.interp(grid, np.maximum.accumulate(eps_up), F_up)
    dn = np.interp(grid, np.maximum.accumulate(eps_dn), F_dn)
    k, se, n = line_fit(grid, 0.5 * (up + dn))
    return k, se, n


# --- magnetic bending (a workbook of tip angles and a field table) ----------------------


def xlsx_sheet(path, name: str) -> dict[str, object]:
    """The cells of sheet ``name`` of an .xlsx workbook as {"C4": value}: read with the standard
    library (the workbook is a zip of XML), numbers as float, shared strings as str. The value
    of a formula cell is the one the workbook saved."""
    import posixpath
    import xml.etree.ElementTree as ET
    import zipfile

    ns = {"m": "http://schemas.openxmlformats.org/spreadsheetml/2006/main"}
    rel = "{http://schemas.openxmlformats.org/officeDocument/2006/relationships}id"
    with zipfile.ZipFile(path) as z:
        book = ET.fromstring(z.read("xl/workbook.xml"))
        rid = next(s.get(rel) for s in book.iterfind("m:sheets/m:sheet", ns) if s.get("name") == name)
        rels = ET.fromstring(z.read("xl/_rels/workbook.xml.rels"))
        target = next(r.get("Target") for r in rels if r.get("Id") == rid)
        shared = []
        if "xl/sharedStrings.xml" in z.namelist():
            for si in ET.fromstring(z.read("xl/sharedStrings.xml")).iterfind("m:si", ns):
                shared.append("".join(t.text or "" for t in si.iter(f"{{{ns['m']}}}t")))
        sheet = ET.fromstring(z.read(posixpath.join("xl", target)))
    cells = {}
    for c in sheet.iter(f"{{{ns['m']}}}c"):
        v = c.find("m:v", ns)
        if v is None:
            continue
        cells[c.get("r")] = shared[int(v.text)] if c.get("t") == "s" else float(v.text)
    return cells


def magnetic_tip(
    path,
    *,
    column: str,
    field_angle_deg: float,
    field_file: str,
    half_length_m: float,
    max_angle_deg: float = 45.0,
    sheet: str = "Figure 3C",
    rows=range(4, 17),
):
    """E_b / (m L) [T] of a magnetised tip in the field of a permanent magnet, read as matid's
    magnetic bending reads a tip magnet in a uniform field: m B sin(psi - theta) = E_b theta / L,
    so B sin(psi - theta) = c + (E_b / (m L)) theta. theta: the workbook's tip angle (deg) in
    ``column``; the distance d from the magnet's centre (mm) in column B; B: the authors' field
    along the magnet's axis (``field_file``, a COMSOL line: height above the face in mm, |B| in
    mT) at height d - ``half_length_m``. Least-squares line over the rows with
    |theta| <= ``max_angle_deg`` (the tip not near the field direction, where sin(psi - theta)
    is lost in the angle's 0.5 deg reading)."""
    cells = xlsx_sheet(path, sheet)
    d = np.array([cells[f"B{r}"] for r in rows]) * 1e-3
    theta = np.deg2rad([cells[f"{column}{r}"] for r in rows])
    h, B = read_table(Path(path).parent / field_file, 8, None).T  # 8 '%' lines of COMSOL's header
    field = np.interp((d - half_length_m) * 1e3, h, B) * 1e-3  # T
    y = field * np.sin(np.deg2rad(field_angle_deg) - theta)
    keep = np.abs(theta) <= np.deg2rad(max_angle_deg)
    return line_fit(theta[keep], y[keep])
