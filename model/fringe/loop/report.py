"""report.md and its plots for `fringe loop`."""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..calib.report import error_plot, lissajous_plot  # noqa: E402
from .evaluation import evaluate  # noqa: E402
from .noise import uniform_run  # noqa: E402
from .run import DECISION_ROWS, DECISION_RUNS  # noqa: E402

PLOT_POINTS = 20_000     # points per scatter plot (the spectra and the map use every sample)


def _spectrum(r: np.ndarray, x: np.ndarray, orders: int) -> np.ndarray:
    """Amplitude (arcsec) of each order of r against the angle x (least squares, one order at a time)."""
    k, rc, acc = np.arange(1, orders + 1), r - r.mean(), np.zeros(orders, complex)
    for start in range(0, len(r), 4096):       # by blocks of samples: memory stays bounded
        sl = slice(start, start + 4096)
        acc += np.exp(-1j * np.outer(k, x[sl])) @ rc[sl]
    return 2 * np.abs(acc) / len(r)


def write_plots(base, state, meas, out_dir: str) -> dict[str, str]:
    meas = meas.runs(DECISION_ROWS, DECISION_RUNS)      # a long recording: the rows the loop decided on
    before, after = evaluate(base, meas), evaluate(state, meas)
    plots = {}
    k = slice(None, None, -(-len(before.r) // PLOT_POINTS))     # scatter plots: evenly strided points
    curves = {"declared model": (before.r[k], before.ctx.phi[k] / (2 * np.pi), before.ctx.psi[k] / (2 * np.pi)),
              "with the added effects": (after.r[k], after.ctx.phi[k] / (2 * np.pi), after.ctx.psi[k] / (2 * np.pi))}
    error_plot(os.path.join(out_dir, "error_vs_angle.png"), curves)
    plots["Error against angle, before and after"] = "error_vs_angle.png"

    fig, axes = plt.subplots(3, 1, figsize=(9, 9))
    for label, ev in (("declared model", before), ("with the added effects", after)):
        axes[0].semilogy(np.arange(1, 33), _spectrum(ev.r, ev.ctx.phi, 32) + 1e-6, ".-", label=label)
        axes[1].semilogy(np.arange(1, 65), _spectrum(ev.r, ev.ctx.psi, 64) + 1e-6, ".-", label=label)
        run = uniform_run(ev.ctx.t)
        r, t = ev.r[run], ev.ctx.t[run]
        dt = np.mean(np.diff(t)) if len(t) > 1 else 1.0
        spec = np.abs(np.fft.rfft((r - r.mean()) * np.hanning(len(r)))) * 4 / len(r)
        axes[2].loglog(np.fft.rfftfreq(len(r), dt)[1:], spec[1:] + 1e-6, "-", lw=0.6, label=label)
    axes[0].set(xlabel="order per signal period", ylabel="amplitude (arcsec)", title="Residual: fine-phase orders")
    axes[1].set(xlabel="order per revolution", ylabel="amplitude (arcsec)", title="Residual: revolution orders")
    axes[2].set(xlabel="frequency (Hz, or 1/sample without t_s)", ylabel="amplitude (arcsec)",
                title="Residual: spectrum over time")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "spectra.png"), dpi=100)
    plt.close(fig)
    plots["Residual spectra by domain"] = "spectra.png"

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (label, ev) in zip(axes, (("declared model", before), ("with the added effects", after)), strict=True):
        img = _map(ev)
        lim = np.nanmax(np.abs(img)) or 1.0
        m = ax.imshow(img, origin="lower", aspect="auto", extent=(0, 360, 0, 360), cmap="RdBu_r", vmin=-lim, vmax=lim)
        ax.set(title=f"{label}: mean error (arcsec)", xlabel="position in the revolution (deg)",
               ylabel="fine phase (electrical deg)")
        fig.colorbar(m, ax=ax)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "error_map.png"), dpi=100)
    plt.close(fig)
    plots["Fine phase x revolution error map"] = "error_map.png"

    lissajous_plot(os.path.join(out_dir, "lissajous.png"), state.cal, meas.sin[k], meas.cos[k])
    plots["Lissajous figure, raw and corrected"] = "lissajous.png"
    return plots


def _map(ev, bins: int = 32) -> np.ndarray:
    i = np.minimum((ev.ctx.phi / (2 * np.pi) * bins).astype(int), bins - 1)
    j = np.minimum((ev.ctx.psi / (2 * np.pi) * bins).astype(int), bins - 1)
    k = i * bins + j
    n = np.bincount(k, minlength=bins * bins)
    s = np.bincount(k, ev.r, minlength=bins * bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, s / np.maximum(n, 1), np.nan).reshape(bins, bins)


def _floor_lines(report: dict) -> list[str]:
    info = report.get("noise_floor_estimates")
    if not info:
        return []
    out = ["", "Noise floor estimates (arcsec): " + "; ".join(f"{k} {v}" for k, v in info["estimates_arcsec"].items())
           + f". {info['note']}."]
    if report.get("float_engine_only"):
        out += ["", "Carried by the float engine only (the bit-exact core runs the rest of the calibration): "
                + ", ".join(report["float_engine_only"]) + "."]
    return out


def write_markdown(report: dict, plots: dict, path: str):
    b, a = report["before"], report["after"]
    out = ["# fringe closed loop", "",
           f"Data: `{report['data']}`; validation: `{report['validation']}`.",
           f"Noise floor estimated from the data: {report['noise_floor_arcsec']}\" RMS "
           f"({report['noise_floor_method']}).", *_floor_lines(report), "",
           "| | RMS | p-p | interpolation p-p | long-period p-p |", "|---|---|---|---|---|",
           f"| declared model (seeds, generalised) | {b['rms_arcsec']} | {b['pp_arcsec']} | "
           f"{b['interp_pp_arcsec']} | {b['lp_pp_arcsec']} |",
           f"| with the added effects | {a['rms_arcsec']} | {a['pp_arcsec']} | {a['interp_pp_arcsec']} | "
           f"{a['lp_pp_arcsec']} |", "", "## Effects added", ""]
    if not report["effects_added"]:
        out.append("None: nothing significant and repeatable was found beyond the declared model.")
    for e in report["effects_added"]:
        out += [f"### {e['name']}: {e['cause']}", "", f"- evidence: {e['evidence']}",
                f"- signature: {e.get('signature', '')}", f"- correction: {e['correction']} ({e['where']})",
                f"- validation RMS: {e['rms_before_arcsec']}\" -> {e['rms_after_arcsec']}\"", ""]
        if e.get("shape"):
            out.insert(-1, f"- shape chosen on held-out data: {e['shape']}")
    if report["effects_rejected"]:
        out += ["## Tried and not kept", ""]
        out += [f"- {e['name']}: {e['evidence']}; {e['why_not_kept']}" for e in report["effects_rejected"]]
        out.append("")
    out += ["## What remains, by domain", "", "| domain | RMS (arcsec) | description |", "|---|---|---|"]
    out += [f"| {u['domain']} | {u['rms_arcsec'] if u['rms_arcsec'] is not None else '-'} | {u['description']} |"
            for u in report["unexplained"]]
    out.append("")
    for title, file in plots.items():
        out += [f"## {title}", "", f"![{title}]({file})", ""]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out))
