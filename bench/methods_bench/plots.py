"""plots.py - the plots (matplotlib): run time against error per dataset, and the renders."""

import os

from .common import mb
from .config import COLOURS, SERIES
from .runs import params


def plots(plt, runs, datasets, baselines, outdir, renders=()):
    os.makedirs(outdir, exist_ok=True)
    made = []

    def save(fig, filename):
        fig.tight_layout()
        p = os.path.join(outdir, filename)
        fig.savefig(p, dpi=110)
        plt.close(fig)
        made.append(p)
    for name in datasets:
        rs = [r for r in runs if r["dataset"] == name]
        fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
        raw = [r for r in rs if r["method"] == "raw"]
        for method in SERIES:
            pts = sorted((r for r in rs if r["series"] == method and r["rmse"] > 0),
                         key=lambda r: r["size_bytes"])
            if not pts:
                continue
            c = COLOURS[method]
            # markers for every configuration, a line through the best error at each size
            front = [r for i, r in enumerate(pts) if all(r["rmse"] < q["rmse"] for q in pts[:i])]
            ax[0].plot([mb(r["size_bytes"]) for r in pts], [r["rmse"] for r in pts], "o",
                       color=c, label=method)
            ax[0].plot([mb(r["size_bytes"]) for r in front], [r["rmse"] for r in front], "-",
                       color=c)
            for r in pts:
                ax[0].annotate(params(r).replace(" ", ","),
                               (mb(r["size_bytes"]), r["rmse"]), fontsize=6, color=c,
                               xytext=(3, 3), textcoords="offset points")
            ax[1].plot([r["factor_seconds"] for r in pts], [r["rmse"] for r in pts], "o",
                       color=c, label=method)
        if raw:
            ax[0].axvline(mb(raw[0]["size_bytes"]), color="black", ls="--",
                          label="raw (dataset) size")
        ax[0].set(xscale="log", yscale="log", xlabel="material size (MB)", ylabel="RMSE of Rd",
                  title=f"{name}: error against size (lines: the best up to each size)")
        ax[1].set(xscale="log", yscale="log", xlabel="factor time, median (s)",
                  ylabel="RMSE of Rd", title=f"{name}: error against factor time")
        for a in ax:
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=8)
        save(fig, f"{name}.png")
    svd = [b for b in baselines if "optimal_log_domain_error" in b]
    if svd:
        fig, axs = plt.subplots(1, len(svd), figsize=(6 * len(svd), 4.5), squeeze=False)
        for a, b in zip(axs[0], svd):
            for e in b["entries"]:
                if e["seconds"] is None or e["error_over_optimal"] is None:
                    continue
                a.plot(e["seconds"], (e["error_over_optimal"] - 1) * 1e6, "o",
                       label=e["who"][:45])
            a.ticklabel_format(axis="y", useOffset=False, style="plain")
            a.set(xscale="log", xlabel="seconds (one channel)",
                  ylabel="error above the optimum (parts per million)",
                  title=f"{b['dataset']}: rank-{b['rank']} SVD of {b['rows']}x{b['cols']}")
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=7)
        save(fig, "svd_baselines.png")
    names = [n for n in datasets if any(r["dataset"] == n for r in renders)]
    if names:
        fig, axs = plt.subplots(2, len(names), figsize=(5.5 * len(names), 9), squeeze=False)
        for col, name in enumerate(names):
            rs = [r for r in renders if r["dataset"] == name]
            top, bot = axs[0][col], axs[1][col]
            for r in rs:
                if r["method"] == "raw":
                    top.axvline(r["render_seconds"], color="black", ls="--",
                                label="raw (the reference) render time")
            for method in SERIES:
                pts = [r for r in rs if r["series"] == method and r["image_rmse"] > 0]
                if not pts:
                    continue
                c = COLOURS[method]
                top.plot([r["render_seconds"] for r in pts], [r["image_rmse"] for r in pts], "o",
                         color=c, label=method)
                bot.plot([r["data_rmse"] for r in pts], [r["image_rmse"] for r in pts], "o",
                         color=c, label=method)
                for r in pts:
                    par = params(r).replace(" ", ",")
                    top.annotate(par, (r["render_seconds"], r["image_rmse"]), fontsize=6,
                                 color=c, xytext=(3, 3), textcoords="offset points")
                    bot.annotate(par, (r["data_rmse"], r["image_rmse"]), fontsize=6,
                                 color=c, xytext=(3, 3), textcoords="offset points")
            r0 = rs[0]
            top.set(yscale="log", xlabel="render time, process wall, median (s)",
                    ylabel="image RMSE against raw",
                    title=f"{name}: image RMSE against render time\n"
                          f"({r0['res']}x{r0['res']}, {r0['spp']} spp, {r0['threads']} threads)")
            bot.set(xscale="log", yscale="log", xlabel="data RMSE of Rd",
                    ylabel="image RMSE against raw", title=f"{name}: image against data error")
            for a in (top, bot):
                a.grid(True, which="both", alpha=0.3)
                a.legend(fontsize=8)
        save(fig, "renders.png")
    return made
