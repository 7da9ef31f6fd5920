#!/usr/bin/env python3
"""Independent checks of `lensim lens info|trace` against a separate implementation.

Written from textbook optics, sharing no code with lensim:
  * surfaces are intersected by Newton's method on the sag equation z = z_v + sag(r) (lensim
    solves a quadratic);
  * refraction uses the tangential-component form of Snell's law (lensim uses the
    cos-based vector form);
  * first-order data come from a y-nu ray trace, forward and on the reversed lens (lensim uses
    2x2 transfer matrices).
It also runs the malformed lens corpus through the CLI and checks `path:line` errors and exit 1.

Usage: check_lens.py --lensim build/lensim --root <repo>
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys

FAILURES = []


def fail(msg):
    FAILURES.append(msg)
    print("FAIL:", msg)


# ---------------------------------------------------------------------------- lens reading
def read_lensim_json(path):
    """A lens in lensim's JSON format, read with Python's json module: spheres as read_rows gives
    them, plus the conic k and the polynomial terms {power: coefficient} of aspheric surfaces."""
    lens = json.load(open(path))
    surfaces, z, n_before = [], 0.0, 1.0
    rows = lens["surfaces"]
    for i, r in enumerate(rows):
        n = r.get("ior", 1.0)
        s = dict(R=r["radius_mm"], z=z, semi=r["semi_aperture_mm"], n0=n_before, n1=n)
        if "conic" in r or "aspheric" in r:
            s["k"] = r.get("conic", 0.0)
            s["poly"] = {int(p): c for p, c in r.get("aspheric", {}).items()}
        surfaces.append(s)
        n_before = n
        if i + 1 < len(rows):
            z += r["thickness_mm"]
    return surfaces


def read_rows(path):
    """Rows of 4 numbers; a lone number before the rows is ISET's focal length (skipped)."""
    if path.endswith(".json"):
        return read_lensim_json(path)
    rows = []
    with open(path, "rb") as f:
        text = f.read().decode()
    for raw in text.replace("\r\n", "\n").replace("\r", "\n").split("\n"):
        line = raw.split("#")[0].split()
        if len(line) == 4:
            rows.append([float(v) for v in line])
    if len(rows) > 1 and rows[0][1] == 0 and rows[0][0] != 0:  # axpos layout
        for i in range(len(rows) - 1):
            rows[i][1] = rows[i + 1][1]
        rows[-1][1] = 0.0
    surfaces = []
    z = 0.0
    n_before = 1.0
    for i, (R, t, N, A) in enumerate(rows):
        N = N if N != 0 else 1.0
        surfaces.append(dict(R=R, z=z, semi=A / 2, n0=n_before, n1=N))
        n_before = N
        if i + 1 < len(rows):
            z += t
    return surfaces


# ---------------------------------------------------------------------------- exact tracing
def sag(R, r):
    if R == 0:
        return 0.0
    return R - math.copysign(math.sqrt(max(0.0, R * R - r * r)), R)


def asph_sag(s, r):
    """Sag of a conic + polynomial surface and its derivative d sag / d r."""
    c = 1.0 / s["R"] if s["R"] != 0 else 0.0
    k = s["k"]
    w = math.sqrt(max(0.0, 1 - (1 + k) * c * c * r * r))
    z = c * r * r / (1 + w)
    dz = c * r / w if w > 0 else float("inf")
    for p, a in s["poly"].items():
        z += a * r ** p
        dz += p * a * r ** (p - 1)
    return z, dz


def asph_intersect(s, o, d):
    """Newton's method on g(t) = z(t) - z_v - sag(r(t)), started where the ray meets the vertex
    plane, with step halving when |g| grows (lensim: closed-form base conic, then Newton)."""
    if abs(d[2]) < 1e-15:
        return None
    t = (s["z"] - o[2]) / d[2]

    def g_of(t):
        x, y, z = (o[k] + t * d[k] for k in range(3))
        r = math.hypot(x, y)
        sg, dsg = asph_sag(s, r)
        g = z - s["z"] - sg
        dg = d[2] - (dsg * (x * d[0] + y * d[1]) / r if r > 0 else 0.0)
        return g, dg

    g, dg = g_of(t)
    for _ in range(100):
        if dg == 0:
            return None
        step = -g / dg
        while True:
            g1, dg1 = g_of(t + step)
            if abs(g1) < abs(g) or abs(step) < 1e-15:
                break
            step *= 0.5
        t += step
        g, dg = g1, dg1
        if abs(step) < 1e-13:
            break
    return t if abs(g) < 1e-9 and t >= -1e-9 else None


def asph_normal(s, p):
    x, y = p[0], p[1]
    r = math.hypot(x, y)
    _, dsg = asph_sag(s, r)
    gx, gy = (dsg * x / r, dsg * y / r) if r > 0 else (0.0, 0.0)
    L = math.sqrt(gx * gx + gy * gy + 1)
    return (gx / L, gy / L, -1 / L)


def intersect(s, o, d):
    """Geometric line/sphere roots (closest approach and half chord), the root on the vertex-side
    cap, then Newton steps on g(t) = z(t) - z_v - sag(r(t)) to polish it."""
    if "k" in s:
        return asph_intersect(s, o, d)
    R = s["R"]
    if R == 0:
        if abs(d[2]) < 1e-15:
            return None
        return (s["z"] - o[2]) / d[2]
    c = (0.0, 0.0, s["z"] + R)
    oc = [c[k] - o[k] for k in range(3)]
    t_c = sum(oc[k] * d[k] for k in range(3))
    dist2 = sum(x * x for x in oc) - t_c * t_c
    if dist2 > R * R:
        return None
    half = math.sqrt(R * R - dist2)
    best = None
    for t in sorted((t_c - half, t_c + half)):
        z = o[2] + t * d[2]
        if t >= -1e-9 and (z - c[2]) * R < 0:  # on the cap that faces the vertex
            best = t
            break
    if best is None:
        return None
    t = best
    for _ in range(5):
        x, y, z = (o[k] + t * d[k] for k in range(3))
        r2 = x * x + y * y
        if r2 >= R * R:
            break
        w = math.sqrt(R * R - r2)
        g = z - s["z"] - sag(R, math.sqrt(r2))
        dg = d[2] - (x * d[0] + y * d[1]) / math.copysign(w, R)
        if dg == 0:
            break
        t -= g / dg
    return t


def normal_at(s, p):
    if "k" in s:
        return asph_normal(s, p)
    R = s["R"]
    if R == 0:
        return (0.0, 0.0, -1.0)
    c = (0.0, 0.0, s["z"] + R)
    v = [(p[k] - c[k]) for k in range(3)]
    L = math.sqrt(sum(x * x for x in v))
    v = [x / L for x in v]
    if v[2] > 0:  # face the scene
        v = [-x for x in v]
    return tuple(v)


def snell(d, n, n1, n2):
    """Tangential form: t_parallel = (n1/n2) (d - (d.n) n); t = t_par + sqrt(1-|t_par|^2) dir."""
    dn = sum(d[k] * n[k] for k in range(3))
    tpar = [(n1 / n2) * (d[k] - dn * n[k]) for k in range(3)]
    s2 = sum(x * x for x in tpar)
    if s2 > 1:
        return None
    along = math.sqrt(1 - s2) * (1 if dn > 0 else -1)
    return tuple(tpar[k] + along * n[k] for k in range(3))


def trace_from_film(surfaces, film_z, film, rear):
    o = (film[0], film[1], film_z)
    tgt = (rear[0], rear[1], surfaces[-1]["z"])
    d = [tgt[k] - o[k] for k in range(3)]
    L = math.sqrt(sum(x * x for x in d))
    d = tuple(x / L for x in d)
    margin = float("inf")
    for i in range(len(surfaces) - 1, -1, -1):
        s = surfaces[i]
        t = intersect(s, o, d)
        if t is None or t < -1e-9:
            return dict(blocked=i, reason="miss", margin=margin)
        p = tuple(o[k] + t * d[k] for k in range(3))
        r = math.hypot(p[0], p[1])
        margin = min(margin, abs(r - s["semi"]))
        if r > s["semi"]:
            return dict(blocked=i, reason="aperture", margin=margin)
        nd = snell(d, normal_at(s, p), s["n1"], s["n0"])
        if nd is None:
            return dict(blocked=i, reason="tir", margin=margin)
        o, d = p, nd
    return dict(origin=o, direction=d, margin=margin)


# ---------------------------------------------------------------------------- paraxial
def ynu_trace(surfs, y, nu):
    """Forward y-nu trace through surfaces given as (c, n_before, n_after, t_to_next)."""
    ys = []
    for k, (c, n0, n1, t) in enumerate(surfs):
        nu = nu - y * (n1 - n0) * c
        ys.append(y)
        if k + 1 < len(surfs):
            y = y + t * nu / n1
    return y, nu, ys


def paraxial(surfaces):
    fwd = []
    for i, s in enumerate(surfaces):
        c = 0.0 if s["R"] == 0 else 1.0 / s["R"]
        t = surfaces[i + 1]["z"] - s["z"] if i + 1 < len(surfaces) else 0.0
        fwd.append((c, s["n0"], s["n1"], t))
    # Reversed lens: order reversed, curvatures negated, media swapped.
    rev = []
    for i in range(len(surfaces) - 1, -1, -1):
        s = surfaces[i]
        c = 0.0 if s["R"] == 0 else -1.0 / s["R"]
        t = s["z"] - surfaces[i - 1]["z"] if i > 0 else 0.0
        rev.append((c, s["n1"], s["n0"], t))
    y_last, nu_last, _ = ynu_trace(fwd, 1.0, 0.0)
    efl = -1.0 / nu_last
    bfl = -y_last / nu_last
    y_first, nu_first, _ = ynu_trace(rev, 1.0, 0.0)
    ffl = -y_first / nu_first  # distance in front of the front vertex
    return dict(efl=efl, bfl=bfl, ffl=ffl)


def ep_check(surfaces):
    """Entrance pupil by brute force: find the object-space axial point imaged to the stop centre
    by intersecting two exact near-axis rays from the stop centre traced to the scene."""
    st = [i for i, s in enumerate(surfaces) if s["R"] == 0][0]
    if st == 0:
        return 0.0, 2 * surfaces[0]["semi"]
    sub = surfaces[:st]
    u = 1e-6
    o = (0.0, 0.0, surfaces[st]["z"])
    d = (-u, 0.0, -1.0)
    L = math.sqrt(sum(x * x for x in d))
    d = tuple(x / L for x in d)
    for i in range(len(sub) - 1, -1, -1):
        s = sub[i]
        t = intersect(s, o, d)
        p = tuple(o[k] + t * d[k] for k in range(3))
        d = snell(d, normal_at(s, p), s["n1"], s["n0"])
        o = p
    z_ep = o[2] - o[0] * d[2] / d[0]
    # Rim ray from the stop edge parallel to the axis (tiny scale, then scaled up: paraxial).
    eps = 1e-6
    o = (eps, 0.0, surfaces[st]["z"])
    d = (0.0, 0.0, -1.0)
    for i in range(len(sub) - 1, -1, -1):
        s = sub[i]
        t = intersect(s, o, d)
        p = tuple(o[k] + t * d[k] for k in range(3))
        d = snell(d, normal_at(s, p), s["n1"], s["n0"])
        o = p
    h = o[0] + (z_ep - o[2]) * d[0] / d[2]
    return z_ep, 2 * surfaces[st]["semi"] * abs(h / eps)


# ---------------------------------------------------------------------------- Zemax files
def read_zmx(path):
    """A .zmx file's surfaces for a paraxial trace, read here with Python's own decoding and a
    whitespace tokeniser (nothing shared with lensim's reader): per lens surface the vertex
    curvature (CURV plus twice the r^2 term of an aspheric polynomial), the index after it (the
    GLAS line's n_d; air without GLAS) and the thickness to the next surface, in mm; the stop;
    and the system aperture (ENPD or FNUM)."""
    raw = open(path, "rb").read()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        text = raw.decode("utf-16")
    else:
        text = raw.decode("utf-8-sig")
    scale = {"MM": 1.0, "CM": 10.0, "IN": 25.4, "M": 1000.0}
    unit = 1.0
    surfs, cur = [], None
    aperture = None
    for line in text.splitlines():
        tok = line.split()
        if not tok:
            continue
        key = tok[0]
        if key == "SURF":
            cur = dict(curv=0.0, disz=None, glass=None, n=None, stop=False, type="STANDARD",
                       parm={})
            surfs.append(cur)
        elif cur is None:
            if key == "UNIT":
                unit = scale[tok[1]]
            elif key == "ENPD":
                aperture = ("ENPD", float(tok[1]))
            elif key == "FNUM":
                aperture = ("FNUM", float(tok[1]))
        elif key == "TYPE":
            cur["type"] = tok[1]
        elif key == "CURV":
            cur["curv"] = float(tok[1])
        elif key == "DISZ":
            cur["disz"] = None if tok[1] == "INFINITY" else float(tok[1])
        elif key == "GLAS":
            cur["glass"] = tok[1]
            # A glass whose n_d a datasheet gives replaces the GLAS line's placeholder.
            cur["n"] = PUBLISHED_ND.get(tok[1], float(tok[4]))
        elif key == "STOP":
            cur["stop"] = True
        elif key == "PARM":
            cur["parm"][int(tok[1])] = float(tok[2])
    lens = []
    stop = None
    for k, z in enumerate(surfs[1:-1]):
        c = z["curv"] / unit
        # r^2 coefficient: EVENASPH PARM 1, ODDASPH PARM 2 (1/length).
        a2 = {"EVENASPH": z["parm"].get(1, 0.0), "ODDASPH": z["parm"].get(2, 0.0)}.get(z["type"], 0.0)
        c += 2 * a2 / unit
        n = z["n"] if z["glass"] else 1.0
        lens.append(dict(c=c, n1=n, t=z["disz"] * unit, glass=z["glass"]))
        if z["stop"]:
            stop = k
    if aperture and aperture[0] == "ENPD":
        aperture = ("ENPD", aperture[1] * unit)
    return lens, (stop if stop is not None else 0), aperture


def zmx_paraxial(lens):
    fwd, n0 = [], 1.0
    for s in lens:
        fwd.append((s["c"], n0, s["n1"], s["t"]))
        n0 = s["n1"]
    rev = []
    for i in range(len(fwd) - 1, -1, -1):
        c, a, b, _ = fwd[i]
        rev.append((-c, b, a, fwd[i - 1][3] if i > 0 else 0.0))
    y_last, nu_last, _ = ynu_trace(fwd, 1.0, 0.0)
    y_first, nu_first, _ = ynu_trace(rev, 1.0, 0.0)
    return dict(efl=-1.0 / nu_last, bfl=-y_last / nu_last, ffl=-y_first / nu_first)


# n_d of glasses lens files name with a placeholder n_d on their GLAS line: B 270, Schott's
# technical details (1.5230, given to 4 decimals).
PUBLISHED_ND = {"B270": 1.5230}


def check_zmx(lensim, path):
    lens, stop, aperture = read_zmx(path)
    ref = zmx_paraxial(lens)
    # At the d line, where the GLAS line's n_d holds (the file's primary wavelength may differ).
    info = run([lensim, "lens", "info", path, "--json", "--wavelength", "587.5618"])
    if info.returncode != 0:
        fail(f"{path}: lens info exited {info.returncode}: {info.stderr}")
        return
    j = json.loads(info.stdout)
    checks = [("effective_focal_length_mm", ref["efl"]), ("back_focal_length_mm", ref["bfl"]),
              ("front_focal_length_mm", ref["ffl"])]
    if aperture and aperture[0] == "ENPD":
        checks.append(("entrance_pupil_diameter_mm", aperture[1]))
    elif aperture:
        checks.append(("f_number", aperture[1]))
    # A datasheet's 4-decimal n_d (+-5e-5) moves the first-order data by up to 5e-5 / (n - 1).
    tol = 1e-4 if any(z["glass"] in PUBLISHED_ND for z in lens) else 1e-6
    for key, mine in checks:
        rel = abs(j[key] - mine) / abs(mine)
        status = "ok" if rel < tol else "FAIL"
        print(f"  {key:28s} lensim {j[key]:14.8f}  independent {mine:14.8f}  rel {rel:.1e} {status}")
        if rel >= tol:
            fail(f"{path}: {key} {j[key]} vs {mine}")


# ---------------------------------------------------------------------------- checks
def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True)


def check_lens(lensim, path, rng):
    surfaces = read_rows(path)
    info = run([lensim, "lens", "info", path, "--json"])
    if info.returncode != 0:
        fail(f"{path}: lens info exited {info.returncode}: {info.stderr}")
        return
    j = json.loads(info.stdout)
    ref = paraxial(surfaces)
    for key, mine in (("effective_focal_length_mm", ref["efl"]),
                      ("back_focal_length_mm", ref["bfl"]),
                      ("front_focal_length_mm", ref["ffl"])):
        rel = abs(j[key] - mine) / abs(ref["efl"])
        status = "ok" if rel < 1e-3 else "FAIL"
        print(f"  {key:28s} lensim {j[key]:12.6f}  independent {mine:12.6f}  rel {rel:.1e} {status}")
        if rel >= 1e-3:
            fail(f"{path}: {key} {j[key]} vs {mine}")
    if any(s["R"] == 0 for s in surfaces):
        z_ep, d_ep = ep_check(surfaces)
        for key, mine in (("entrance_pupil_z_mm", z_ep), ("entrance_pupil_diameter_mm", d_ep)):
            err = abs(j[key] - mine)
            ok = err < 1e-3 * max(1.0, abs(mine))
            print(f"  {key:28s} lensim {j[key]:12.6f}  independent {mine:12.6f}  err {err:.1e} "
                  f"{'ok' if ok else 'FAIL'}")
            if not ok:
                fail(f"{path}: {key} {j[key]} vs {mine}")

    # Exact rays at two film distances.
    film_distances = [j["film_distance_mm"], j["film_distance_mm"] * 1.05]
    rear_semi = surfaces[-1]["semi"]
    n_ok = n_blocked = n_skipped = 0
    worst_pos = worst_dir = 0.0
    for fd in film_distances:
        film_z = surfaces[-1]["z"] + fd
        attempts = 0
        through_before = n_ok
        while attempts < 200 and n_ok - through_before < 12:
            attempts += 1
            r, a = rear_semi * math.sqrt(rng.random()), 2 * math.pi * rng.random()
            rear = (r * math.cos(a), r * math.sin(a))
            fr, fa = 0.4 * fd * math.sqrt(rng.random()), 2 * math.pi * rng.random()
            film = (fr * math.cos(fa), fr * math.sin(fa))
            mine = trace_from_film(surfaces, film_z, film, rear)
            if mine["margin"] < 1e-6:
                n_skipped += 1  # too close to a rim for a fair comparison
                continue
            out = run([lensim, "lens", "trace", path, "--film-distance", repr(fd), "--film",
                       f"{film[0]!r},{film[1]!r}", "--rear", f"{rear[0]!r},{rear[1]!r}", "--json"])
            if out.returncode != 0:
                fail(f"{path}: lens trace exited {out.returncode}: {out.stderr}")
                continue
            t = json.loads(out.stdout)
            if "origin" in mine:
                if "origin_mm" not in t:
                    fail(f"{path}: film {film} rear {rear}: lensim blocked ({t.get('reason')}), "
                         "independent tracer passes")
                    continue
                dp = max(abs(t["origin_mm"][k] - mine["origin"][k]) for k in range(3))
                dd = max(abs(t["direction"][k] - mine["direction"][k]) for k in range(3))
                worst_pos, worst_dir = max(worst_pos, dp), max(worst_dir, dd)
                n_ok += 1
                if dp > 1e-6 or dd > 1e-9:
                    fail(f"{path}: film {film} rear {rear}: origin differs by {dp}, direction by {dd}")
            else:
                n_blocked += 1
                if t.get("blocked_at_surface") != mine["blocked"] or t.get("reason") != mine["reason"]:
                    fail(f"{path}: film {film} rear {rear}: lensim {t.get('blocked_at_surface')}/"
                         f"{t.get('reason')}, independent {mine['blocked']}/{mine['reason']}")
    print(f"  rays: {n_ok} through, {n_blocked} blocked, {n_skipped} skipped near rims; "
          f"max |origin diff| {worst_pos:.1e} mm, max |direction diff| {worst_dir:.1e}")
    if n_ok < 20:
        fail(f"{path}: only {n_ok} rays got through; the comparison is too thin")


def check_convert(lensim, root):
    """`lens convert` to lensim JSON validates against docs/lens.schema.json (python3-jsonschema,
    not lensim's code) and reads back with the same first-order data; .dat refuses aspheres."""
    import tempfile
    import jsonschema
    schema = json.load(open(os.path.join(root, "docs", "lens.schema.json")))
    tmp = tempfile.mkdtemp(prefix="lensim-convert-")
    sources = [os.path.join(root, "lenses", "dgauss.50mm.dat"), "lentil:0014", "lentil:2004",
               os.path.join(root, "..", "shared", "lenses", "zmx", "ACL3026U-Zemax(ZMX).zmx"),
               os.path.join(root, "tests", "data", "iset", "dgauss.77deg.3.5201mm.json")]
    for k, src in enumerate(sources):
        out = os.path.join(tmp, f"lens{k}.json")
        r = run([lensim, "lens", "convert", src, out, "--model-glass"])
        if r.returncode != 0:
            fail(f"convert {src}: exit {r.returncode} {r.stderr}")
            continue
        try:
            jsonschema.validate(json.load(open(out)), schema)
        except jsonschema.ValidationError as e:
            fail(f"convert {src}: the JSON does not follow the schema: {e.message}")
        a = json.loads(run([lensim, "lens", "info", src, "--json", "--model-glass"]).stdout)
        b = json.loads(run([lensim, "lens", "info", out, "--json"]).stdout)
        if abs(a["effective_focal_length_mm"] - b["effective_focal_length_mm"]) > 1e-9 * abs(
                a["effective_focal_length_mm"]):
            fail(f"convert {src}: EFL {a['effective_focal_length_mm']} -> {b['effective_focal_length_mm']}")
    r = run([lensim, "lens", "convert", "lentil:0014", os.path.join(tmp, "x.dat")])
    if r.returncode != 1 or "cannot be written to .dat" not in r.stderr or os.path.exists(
            os.path.join(tmp, "x.dat")):
        fail(f"convert asphere to .dat: exit {r.returncode} {r.stderr!r}")
    print(f"  lens convert: {len(sources)} lenses to schema-valid JSON, same EFL; .dat refuses aspheres")


def check_bad_corpus(lensim, root):
    folder = os.path.join(root, "tests", "data", "bad_lenses")
    count = 0
    with open(os.path.join(folder, "expected.txt")) as f:
        for line in f:
            if not line.strip() or line.startswith("#"):
                continue
            name, ln, col, msg = [x.strip() for x in line.split("|", 3)]
            path = os.path.join(folder, name)
            out = run([lensim, "lens", "info", path])
            prefix = f"{path}:{ln}:" + (f"{col}:" if col != "0" else "")
            count += 1
            if out.returncode != 1:
                fail(f"{name}: exit code {out.returncode}, expected 1")
            if not out.stderr.startswith(prefix + " error: ") or msg not in out.stderr:
                fail(f"{name}: stderr {out.stderr!r} does not start with {prefix!r} or lacks {msg!r}")
            if out.stdout:
                fail(f"{name}: printed output despite the error")
    missing = run([lensim, "lens", "info", os.path.join(folder, "does-not-exist.dat")])
    if missing.returncode != 1 or "cannot open lens file" not in missing.stderr:
        fail(f"missing file: {missing.returncode} {missing.stderr!r}")
    print(f"  malformed corpus: {count} files checked")


def check_pictures(lensim, root):
    """lens draw / lens plot through the CLI: valid SVG, numbers exposed, errors exit 1."""
    import tempfile
    tmp = tempfile.mkdtemp(prefix="lensim-pictures-")
    lenses = [os.path.join(root, "lenses", f) for f in
              ("dgauss.50mm.dat", "fisheye.10mm.dat", "wide.22mm.dat", "telephoto.250mm.dat")]
    sheet = os.path.join(tmp, "lenses.svg")
    out = run([lensim, "lens", "draw", *lenses, "-o", sheet])
    if out.returncode != 0 or not os.path.exists(sheet):
        fail(f"lens draw: exit {out.returncode} {out.stderr}")
    elif run(["xmllint", "--noout", sheet]).returncode != 0:
        fail("lens draw: the SVG is not well-formed")
    for kind in ("spot", "distortion", "vignetting", "focus"):
        svg = os.path.join(tmp, kind + ".svg")
        out = run([lensim, "lens", "plot", kind, lenses[0], "-o", svg, "--json"])
        if out.returncode != 0:
            fail(f"lens plot {kind}: exit {out.returncode} {out.stderr}")
            continue
        data = json.loads(out.stdout)
        if data["kind"] != kind or run(["xmllint", "--noout", svg]).returncode != 0:
            fail(f"lens plot {kind}: bad JSON or SVG")
        if kind == "distortion" and not abs(data["percent_tan"][-1]) < 5:
            fail(f"double Gauss distortion {data['percent_tan'][-1]}% at the corner")
    # Errors: exit 1, a message, and no file left behind.
    bad = os.path.join(tmp, "missing-dir", "x.svg")
    out = run([lensim, "lens", "draw", lenses[0], "-o", bad])
    if out.returncode != 1 or "error" not in out.stderr or os.path.exists(bad):
        fail(f"draw into a missing directory: exit {out.returncode} {out.stderr!r}")
    out = run([lensim, "lens", "plot", "spot", os.path.join(tmp, "nope.dat"), "-o",
               os.path.join(tmp, "nope.svg")])
    if out.returncode != 1 or os.path.exists(os.path.join(tmp, "nope.svg")):
        fail(f"plot of a missing lens: exit {out.returncode}")
    leftovers = [f for f in os.listdir(tmp) if ".tmp-" in f]
    if leftovers:
        fail(f"temporary files left behind: {leftovers}")
    print("  lens draw / lens plot: SVG, JSON and errors checked")


def check_analyses(lensim, root):
    """lens plot mtf|mtf-focus|fans|field|psf on every classic and ISET lens of ../shared: valid
    SVG, finite JSON numbers, MTF 1 at zero frequency and within [0, 1], the on-axis diffraction
    MTF below the aberration-free MTF of its own cone (|OTF| <= the pupil's autocorrelation)."""
    import glob
    import tempfile
    tmp = tempfile.mkdtemp(prefix="lensim-analyses-")
    shared = os.path.join(root, "..", "shared", "lenses")
    lenses = sorted(glob.glob(os.path.join(shared, "*.dat")) +
                    glob.glob(os.path.join(shared, "isetcam", "*.dat")))
    if len(lenses) < 10:
        fail(f"expected the classic and ISET lenses in {shared}, found {len(lenses)}")
    count = 0
    for lens in lenses:
        name = os.path.basename(lens)
        for kind in ("mtf", "mtf-focus", "fans", "field", "psf"):
            svg = os.path.join(tmp, f"{name}-{kind}.svg")
            # A small pupil grid keeps the sweep fast; the default (automatic) grid is checked
            # on the double Gauss below.
            extra = ["--pupil-cells", "48"] if kind in ("mtf", "mtf-focus", "psf") else []
            out = run([lensim, "lens", "plot", kind, lens, "-o", svg, "--json", *extra])
            count += 1
            if out.returncode != 0:
                fail(f"{name} {kind}: exit {out.returncode} {out.stderr}")
                continue
            if run(["xmllint", "--noout", svg]).returncode != 0:
                fail(f"{name} {kind}: the SVG is not well-formed")
            data = json.loads(out.stdout)
            if data["kind"] != kind or not data.get("wavelengths"):
                fail(f"{name} {kind}: bad JSON header")
            if kind != "field" and not data["fields"]:
                fail(f"{name} {kind}: no field computed")
            if kind == "mtf":
                check_mtf_json(name, data)
            elif kind == "mtf-focus":
                for f in data["fields"]:
                    vals = f["tangential"] + f["sagittal"]
                    if len(f["tangential"]) != len(data["defocus_mm"]) or \
                            not all(-1e-9 <= v <= 1 + 1e-9 for v in vals):
                        fail(f"{name} mtf-focus: bad values")
            elif kind == "fans":
                for f in data["fields"]:
                    for fan in f["fans"]:
                        if len(fan["tangential_pupil"]) != len(fan["tangential_ex_mm"]) or \
                                not fan["tangential_pupil"]:
                            fail(f"{name} fans: empty or mismatched fan")
            elif kind == "field":
                n = len(data["field_angle_deg"])
                if n < 2 or len(data["tangential_focus_mm"][0]) != n or \
                        abs(data["tangential_focus_mm"][0][0] - data["sagittal_focus_mm"][0][0]) > 1e-6:
                    fail(f"{name} field: bad curves (axial T and S foci must coincide)")
            elif kind == "psf":
                for f in data["fields"]:
                    if not 0 < f["strehl"] <= 1.0001 or f["pixels"] <= 0:
                        fail(f"{name} psf: Strehl {f['strehl']}")
    # The default automatic pupil grid, and polychromatic weights.
    svg = os.path.join(tmp, "auto.svg")
    out = run([lensim, "lens", "plot", "mtf", os.path.join(root, "lenses", "dgauss.50mm.dat"),
               "-o", svg, "--json", "--wavelengths", "486.13:1,587.56:2,656.27:1",
               "--max-frequency", "200"])
    if out.returncode != 0:
        fail(f"mtf with three wavelengths: exit {out.returncode} {out.stderr}")
    else:
        data = json.loads(out.stdout)
        check_mtf_json("dgauss.50mm (3 wavelengths)", data)
        if len(data["wavelengths"]) != 3 or abs(data["frequency_cycles_per_mm"][-1] - 200) > 1e-9:
            fail("mtf: --wavelengths or --max-frequency ignored")
    for bad in (["--wavelengths", "abc"], ["--wavelengths", "587:-1"], ["--pupil-cells", "3"],
                ["--fields", "-1"], ["--fields", "1.4", "--film-diagonal", "200"]):
        out = run([lensim, "lens", "plot", "mtf", os.path.join(root, "lenses", "dgauss.50mm.dat"),
                   "-o", os.path.join(tmp, "bad.svg"), *bad])
        if out.returncode != 1 or "error" not in out.stderr or os.path.exists(os.path.join(tmp, "bad.svg")):
            fail(f"mtf {bad}: exit {out.returncode} {out.stderr!r}")
    print(f"  lens plot mtf/mtf-focus/fans/field/psf: {count} plots on {len(lenses)} lenses checked")


def check_real_f_numbers(lensim, root):
    """lens info --json: the real-ray f-numbers and stops of the independent comparison with an
    optical design library (issue 17), and the ISET reversed telephoto's focus beyond infinity."""
    shared = os.path.join(root, "..", "shared", "lenses")
    cases = [(os.path.join(root, "lenses", "dgauss.50mm.dat"), 2.018, 2, 5),
             (os.path.join(root, "lenses", "wide.22mm.dat"), 2.788, 6, 5),
             (os.path.join(shared, "isetcam", "petzval.12deg.50.0mm.dat"), 1.400, 5, 5)]
    for path, f_real, limit, stop in cases:
        out = run([lensim, "lens", "info", path, "--json"])
        if out.returncode != 0:
            fail(f"lens info {path}: exit {out.returncode}")
            continue
        j = json.loads(out.stdout)
        if abs(j["real_f_number"] - f_real) > 0.0015 or j["real_limit_surface"] != limit or \
                j["aperture_stop_surface"] != stop or j["paraxial_f_number"] != j["f_number"]:
            fail(f"{os.path.basename(path)}: real f/{j['real_f_number']:.4f} limited by "
                 f"{j['real_limit_surface']}, stop {j['aperture_stop_surface']}; expected "
                 f"f/{f_real} by {limit}, stop {stop}")
    out = run([lensim, "lens", "info", "--json",
               os.path.join(shared, "isetcam", "reversed.telephoto.37deg.100mm.dat")])
    j = json.loads(out.stdout) if out.returncode == 0 else {}
    if not j.get("focus_beyond_infinity") or j.get("focus_at_infinity") or \
            abs(j.get("film_in_front_of_infinity_focus_mm", 0) - 0.224) > 0.001 or \
            j.get("aperture_stop_is_file_stop"):
        fail(f"reversed telephoto: focus/stop report {out.returncode} {out.stdout[:200]}")
    print("  real f-numbers, real-ray stops and the focus beyond infinity checked")


def check_mtf_json(name, data):
    for f in data["fields"]:
        for key in ("diffraction_tangential", "diffraction_sagittal", "geometric_tangential",
                    "geometric_sagittal"):
            v = f[key]
            if len(v) != len(data["frequency_cycles_per_mm"]) or abs(v[0] - 1) > 1e-9 or \
                    not all(-1e-9 <= x <= 1 + 1e-9 for x in v):
                fail(f"{name} mtf: {key} not an MTF")
        if f["field_fraction"] == 0:
            for a, b in zip(f["diffraction_tangential"], data["diffraction_limit"]):
                if a > b + 0.03:
                    fail(f"{name} mtf: on-axis MTF {a} above the diffraction limit {b}")
                    break


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lensim", required=True)
    ap.add_argument("--root", required=True)
    args = ap.parse_args()
    rng = random.Random(2024)
    lenses = ["dgauss.50mm.dat", "fisheye.10mm.dat", "wide.22mm.dat", "telephoto.250mm.dat",
              "isetcam/tessar.22deg.50.0mm.dat", "axpos/telephoto.dat"]
    for name in lenses:
        print(name)
        check_lens(args.lensim, os.path.join(args.root, "lenses", name), rng)
    # Aspheric surfaces (conic + polynomial), traced by the Newton solver above.
    print("tests/data/lenses/asphere-doublet.json")
    check_lens(args.lensim, os.path.join(args.root, "tests", "data", "lenses", "asphere-doublet.json"),
               rng)
    shared = os.path.join(args.root, "..", "shared", "lenses", "zmx")
    for name in ("ACL3026U-Zemax(ZMX).zmx", "US00583336-2-scaled.zmx"):
        print(name)
        check_zmx(args.lensim, os.path.join(shared, name))
    check_convert(args.lensim, args.root)
    check_bad_corpus(args.lensim, args.root)
    check_pictures(args.lensim, args.root)
    check_analyses(args.lensim, args.root)
    check_real_f_numbers(args.lensim, args.root)
    if FAILURES:
        print(f"{len(FAILURES)} failures")
        return 1
    print("all independent checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
