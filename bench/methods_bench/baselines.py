"""baselines.py - what a user would otherwise use, on one channel of the same matrices:
scikit-learn's randomized_svd and NMF, and a full LAPACK SVD for the optimal error."""

import json
import math
import os
import time

from .common import run
from .config import LOG_A, LOG_B, RANDOM_STATE
from .files import opm_array, opm_sections
from .runs import timed


def shifted_channel(np, rd):
    """The svd method's preprocessing of one channel (docs/formats.md): (g, mx, s) with g the
    given values circularly shifted so each row's (first) largest cleaned value comes first,
    mx that value, s = clean(g) / mx (0 for rows without a positive value); float32."""
    clean = np.where(np.isfinite(rd) & (rd > 0), rd, 0).astype(np.float32)
    shift = clean.argmax(axis=1)
    mx = clean[np.arange(rd.shape[0]), shift]
    idx = (np.arange(rd.shape[1])[None, :] + shift[:, None]) % rd.shape[1]
    g = np.take_along_axis(np.asarray(rd, dtype=np.float32), idx, axis=1)
    s = np.take_along_axis(clean, idx, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(mx[:, None] > 0, s / mx[:, None], 0).astype(np.float32)
    return g, mx, s


def svd_rd_rmse(np, u, v, g, mx):
    """RMSE against the given values g (shifted like the factors) of the svd reconstruction
    max * max(0, A (exp(U V^T) - 1) + A (1 - B)), by row blocks in double."""
    se = 0.0
    for i in range(0, g.shape[0], 8192):
        x = u[i:i + 8192].astype(np.float64) @ v.astype(np.float64).T
        r = np.maximum(0, LOG_A * np.expm1(x) + LOG_A * (1 - LOG_B)) * mx[i:i + 8192, None]
        se += float(((r - g[i:i + 8192]) ** 2).sum())
    return math.sqrt(se / g.size)


def frob_err(np, m, u, v):
    """||m - u v^T||_F in double, by row blocks."""
    se = 0.0
    for i in range(0, m.shape[0], 8192):
        d = m[i:i + 8192].astype(np.float64) - u[i:i + 8192].astype(np.float64) @ v.T
        se += float((d * d).sum())
    return math.sqrt(se)


def svd_baseline(np, skx, rec, ds_path, repeats, tool, work, log):
    """Opaline's svd (rec, a T-term run) against scikit-learn's randomized_svd and LAPACK on
    channel 0 of the same preprocessed matrix. Opaline's SVD is timed twice: like the peer
    (opaline-bench-rsvd on the very matrix handed to scikit-learn, median of at least 3 runs in
    one process; the goal's figure) and inside opaline-factor (channel 0 of a fresh process,
    so with the BLAS library's start-up)."""
    secs, meta = opm_sections(ds_path)
    cols = int(meta["kernel"]) ** 2
    ch = "RD." + ("Y" if meta["channels"] == "1" else "R")
    rd = opm_array(np, ds_path, secs, ch, np.float32, cols)
    g, mx, s = shifted_channel(np, rd)
    m = np.log1p(s / np.float32(LOG_A) + np.float32(LOG_B - 1)).astype(np.float32)
    T = int(rec["T"])
    msecs, mmeta = opm_sections(rec["material"])
    tag = ch[3:]
    u = np.array(opm_array(np, rec["material"], msecs, "U." + tag, np.float32, T))
    v = np.array(opm_array(np, rec["material"], msecs, "V." + tag, np.float32, T))
    res = {"dataset": rec["dataset"], "channel": tag, "rows": m.shape[0], "cols": m.shape[1],
           "rank": T, "entries": []}
    norm = float(np.linalg.norm(m.astype(np.float64)))

    def entry(who, seconds, uu, vv, extra=None):
        e = {"who": who, "seconds": seconds,
             "log_domain_error": frob_err(np, m, uu, vv) / norm if uu is not None else None,
             "rd_rmse": svd_rd_rmse(np, uu, vv, g, mx) if uu is not None else None}
        e.update(extra or {})
        res["entries"].append(e)
        return e

    runs = max(repeats, 3)  # opaline and scikit-learn alike: the median of at least 3
    bench = os.path.join(os.path.dirname(tool), "opaline-bench-rsvd")
    mat = os.path.join(work, f"{rec['dataset']}.channel0.f32")
    fac = mat[:-4] + ".factors.f32"
    m.tofile(mat)
    try:
        stdout = run([bench, mat, str(m.shape[0]), str(m.shape[1]), str(T), "--repeats",
                      str(runs), "--factors", fac], log)[0]
    finally:
        os.remove(mat)
    timing = json.loads(stdout)
    f = np.fromfile(fac, dtype=np.float32)
    os.remove(fac)
    nu = m.shape[0] * T
    entry("opaline svd (randomized, p=10, q<=4 stopping when converged, float32)",
          timing["median_seconds"], f[:nu].reshape(m.shape[0], T), f[nu:].reshape(m.shape[1], T),
          {"seconds_of": "op_rsvd on this matrix, median of runs in one process "
                         "(opaline-bench-rsvd), as scikit-learn is timed",
           "seconds_runs": timing["seconds"]})
    entry("opaline-factor's svd, channel 0 (a fresh process: with BLAS start-up)",
          rec["channel0_seconds"], u, v,
          {"seconds_of": "the SVD of channel 0 alone inside opaline-factor, median of the runs "
                         "above"})
    if skx is not None:
        rs = skx.randomized_svd
        t, (uu, ss, vt) = timed(lambda: rs(m, T, random_state=RANDOM_STATE), runs)
        entry("sklearn randomized_svd (defaults: n_iter auto=7, p=10)", t, uu * ss, vt.T)
        t, (uu, ss, vt) = timed(lambda: rs(m, T, n_oversamples=10, n_iter=4,
                                           random_state=RANDOM_STATE), runs)
        entry("sklearn randomized_svd (n_iter=4, p=10: opaline's maximum)", t, uu * ss, vt.T)
    m64 = m.astype(np.float64)
    t = time.perf_counter()
    uu, ss, vt = np.linalg.svd(m64, full_matrices=False)
    t = time.perf_counter() - t
    opt = math.sqrt(float((ss[T:].astype(np.float64) ** 2).sum())) / norm
    e = entry("LAPACK full SVD (numpy, float64, gesdd), truncated: the optimum", t,
              uu[:, :T] * ss[:T], vt[:T].T)
    e["log_domain_error"] = opt
    del uu, vt, m64
    res["optimal_log_domain_error"] = opt
    for e in res["entries"]:
        e["error_over_optimal"] = (e["log_domain_error"] / opt if opt > 0 and
                                   e["log_domain_error"] is not None else None)
    return res


def nmf_baseline(np, skd, rec, ds_path):
    """Opaline's nmf (rec) against scikit-learn's NMF on channel 0 of the same remainder
    Q = Rd / (SCALE PROF), with the same rank; errors in Rd after reconstruction."""
    secs, meta = opm_sections(ds_path)
    cols = int(meta["kernel"]) ** 2
    ch = "RD." + ("Y" if meta["channels"] == "1" else "R")
    tag = ch[3:]
    rd = np.asarray(opm_array(np, ds_path, secs, ch, np.float32, cols))
    T = int(rec["T"])
    msecs, _ = opm_sections(rec["material"])
    prof = np.asarray(opm_array(np, rec["material"], msecs, "PROF." + tag, np.float32))
    scale = np.asarray(opm_array(np, rec["material"], msecs, "SCALE." + tag, np.float32))
    w = np.asarray(opm_array(np, rec["material"], msecs, "W." + tag, np.float32, T))
    h = np.asarray(opm_array(np, rec["material"], msecs, "H." + tag, np.float32, T))
    hom = scale[:, None].astype(np.float64) * prof[None, :]
    clean = np.where(np.isfinite(rd) & (rd > 0), rd, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.minimum(np.where(hom > 0, clean / hom, 0), 1e30).astype(np.float32)

    def rmse(ww, hh):
        return float(np.sqrt(np.mean((hom * (ww.astype(np.float64) @ hh.T) - rd) ** 2)))

    def qerr(ww, hh):
        return float(np.linalg.norm(q - ww @ hh.T) / np.linalg.norm(q))

    res = {"dataset": rec["dataset"], "channel": tag, "rows": rd.shape[0], "cols": cols,
           "rank": T, "entries": [
               {"who": "opaline nmf (HALS from NNDSVD, tol 1e-4, at most 200 iterations)",
                "seconds": rec["channel0_seconds"], "rd_rmse": rmse(w, h),
                "remainder_relative_error": qerr(w, h)}]}
    if skd is not None:
        import warnings
        model = skd.NMF(n_components=T, init=None, solver="cd", tol=1e-4, max_iter=200,
                        random_state=RANDOM_STATE)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            ww = model.fit_transform(q)
            t = time.perf_counter() - t
        hh = model.components_.T
        res["entries"].append({
            "who": "sklearn NMF (defaults: cd solver, init nndsvda, tol 1e-4, max_iter 200)",
            "seconds": t, "rd_rmse": rmse(ww, hh), "remainder_relative_error": qerr(ww, hh),
            "iterations": int(model.n_iter_)})
    return res
