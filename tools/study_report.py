#!/usr/bin/env python3
"""Charts and report.md for `basalt study` (host/study/study.cpp writes study.json).

Usage: study_report.py DIR/study.json [--seconds S]

With --seconds (the time `basalt study --budget` leaves it), the charts are drawn most
important first (the spp chart, then relMSE, then 1 - SSIM per device) and a chart that would
not finish in time, judged by the slowest chart so far, is skipped and named in report.md.

Writes beside study.json:
  chart-<device>.png       relMSE against render time, log-log, one panel per knob
  chart-<device>-ssim.png  the same for 1 - SSIM
  chart-spp.png            the default curve against spp with the fit relMSE = a / spp + c
  report.md                tables and one sentence per setting, the charts embedded

Exits 3 (and still writes report.md, without charts) when matplotlib cannot be imported:
install Debian's python3-matplotlib.
"""
import json
import math
import os
import sys
import time

EXIT_NO_MATPLOTLIB = 3


def finite(x):
    """True for a number that is neither None, NaN nor infinite."""
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def curve(points, device, knob, value=None):
    """Measured points of one setting on one device, by spp ascending."""
    out = [p for p in points
           if p["device"] == device and p["knob"] == knob and (value is None or p["value"] == value)
           and p["seeds"] > 0]
    return sorted(out, key=lambda p: p["spp"])


def loglog_at(xs, ys, x):
    """y at x on the polyline (xs, ys) in log-log space, or None outside its range (no
    extrapolation: render times of a few spp are too noisy to extend a slope from)."""
    pts = sorted((a, b) for a, b in zip(xs, ys) if finite(a) and finite(b) and a > 0 and b > 0)
    if not finite(x) or x <= 0 or not pts or x < pts[0][0] or x > pts[-1][0]:
        return None
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if x0 <= x <= x1:
            if x1 == x0:
                return y0
            t = math.log(x / x0) / math.log(x1 / x0)
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    return pts[0][1]  # a single point at exactly x


def pareto(pts):
    """The (time, error) points no other point beats in both, by time ascending."""
    front, best = [], math.inf
    for t, e in sorted(pts):
        if e < best:
            front.append((t, e))
            best = e
    return front


def default_label(study, knob, named=False):
    """The default setting of a knob in words ("the scene's (5)", "power"), with the knob's
    name when \p named ("the scene's maxdepth (5)", "mis power")."""
    d = knob["default"]
    q = study.get("default_quality") or {}
    key = knob["name"].replace("-", "_")
    name = knob["name"] + " " if named else ""
    if d == "scene":
        known = key in q and q[key] != "scene"
        return ("the scene's " + name + ("(%s)" % q[key] if known else "")).strip()
    return name + d


def ratio_words(r, noun):
    """'3 % more time', '40 % less error', '2.5x the time'."""
    if not finite(r):
        return "%s unknown" % noun
    if r >= 1.995:
        return "%.1fx the %s" % (r, noun)
    pct = (r - 1.0) * 100.0
    if abs(pct) < 0.5:
        return "the same %s" % noun
    return "%.0f %% %s %s" % (abs(pct), "more" if pct > 0 else "less", noun)


def fmt(x, spec="%.3g"):
    """A number for a table, or an en dash."""
    return spec % x if finite(x) else "–"


def fmt_ratio(r):
    """A ratio for a table: 0.62x."""
    return "%.2fx" % r if finite(r) else "–"


def common_spp(a, b):
    """Highest spp at which both curves have a point."""
    s = {p["spp"] for p in a} & {p["spp"] for p in b}
    return max(s) if s else None


def at_spp(c, spp):
    """The point of curve c at spp."""
    return next((p for p in c if p["spp"] == spp), None)


def equal_time(default, setting, metric="rel_mse_mean"):
    """Per spp of the default: (spp, setting's error at the default's render time over the
    default's error), where the setting's measured times bracket the default's."""
    xs = [p["seconds_render"] for p in setting]
    ys = [p[metric] for p in setting]
    out = []
    for d in default:
        e = loglog_at(xs, ys, d["seconds_render"])
        if e is not None and finite(d[metric]) and d[metric] > 0:
            out.append((d["spp"], e / d[metric]))
    return out


def time_spread(points, device):
    """Median relative sd of render time over seeds, over the default's points on a device
    (None without repeated seeds): the run-to-run noise of a time."""
    r = sorted(p["seconds_render_sd"] / p["seconds_render"]
               for p in curve(points, device, "default")
               if p["seeds"] >= 2 and finite(p.get("seconds_render_sd"))
               and finite(p["seconds_render"]) and p["seconds_render"] > 0)
    return r[len(r) // 2] if r else None


def idle_deviations(study, device):
    """|render time / default's - 1| of the image-knob settings whose images equal the
    default's: they do the same work, so these deviations are timing noise."""
    points = study["points"]
    default = curve(points, device, "default")
    out = []
    for k in study["knobs"]:
        if k["kind"] != "image" or k["name"] == "spp":
            continue
        for v in k["values"]:
            c = curve(points, device, k["name"], v)
            n = common_spp(default, c)
            if n and identical(c):
                d, s = at_spp(default, n), at_spp(c, n)
                r = s["seconds_render"] / d["seconds_render"] if finite(s["seconds_render"]) \
                    and finite(d["seconds_render"]) and d["seconds_render"] > 0 else None
                if r is not None:
                    out.append(abs(r - 1.0))
    return sorted(out)


def time_noise(study, device):
    """Relative time difference that counts as noise on a device: twice the run-to-run spread,
    or, from three or more idle settings, the 90th percentile of their deviations if larger."""
    spread = time_spread(study["points"], device)
    tol = 2.0 * spread if finite(spread) else None
    idle = idle_deviations(study, device)
    if len(idle) >= 3:
        p90 = idle[min(len(idle) - 1, int(0.9 * len(idle)))]
        tol = max(tol or 0.0, p90)
    return tol


def pct(r):
    """(r - 1) in percent, with no "-0"."""
    v = (r - 1.0) * 100.0 if finite(r) else float("nan")
    return 0.0 if abs(v) < 0.5 else v


def time_words(r, noise, noun="time"):
    """A time ratio in words, 'the same time' when within the timing noise."""
    if finite(r) and finite(noise) and abs(r - 1.0) < noise:
        return "the same %s within the timing noise (%+.0f %%)" % (noun, pct(r))
    return ratio_words(r, noun)


def identical(setting):
    """True if every measured image of the setting equals the default's (same spp and seed)."""
    diffs = [p.get("max_abs_diff_vs_default") for p in setting]
    return bool(diffs) and all(d == 0 for d in diffs)


def sentence(study, knob, value, default, setting, spread):
    """One sentence in words and numbers on a non-default setting against the default."""
    dl = default_label(study, knob, named=True)
    head = "%s %s instead of %s" % (knob["name"], value, dl)
    n = common_spp(default, setting)
    if n is None:
        return head + ": no spp measured for both (budget)."
    d, s = at_spp(default, n), at_spp(setting, n)
    rt = s["seconds_render"] / d["seconds_render"] if finite(s["seconds_render"]) and \
        finite(d["seconds_render"]) and d["seconds_render"] > 0 else None
    if knob["kind"] == "image" and identical(setting):
        return "%s: the same images as the default at every measured spp (max |Δ| = 0: it " \
               "changes nothing in this scene), so the %+.0f %% in time at %d spp is timing " \
               "noise." % (
                   head, pct(rt), n)
    if knob["kind"] == "time":
        diff = s.get("max_abs_diff_vs_default")
        same = ("images identical (max |Δ| = 0)" if diff == 0 else
                "images differ (max |Δ| = %.3g): not a pure time knob" % diff if finite(diff) else
                "identity not checked (no default image at the same spp and seed)")
        rp = s["seconds_process"] / d["seconds_process"] if finite(s["seconds_process"]) and \
            finite(d["seconds_process"]) and d["seconds_process"] > 0 else None
        return "%s: %s; %s, %s (at %d spp)." % (
            head, same, time_words(rt, spread, "render time"),
            time_words(rp, spread, "process time"), n)
    re_ = s["rel_mse_mean"] / d["rel_mse_mean"] if finite(s["rel_mse_mean"]) and \
        finite(d["rel_mse_mean"]) and d["rel_mse_mean"] > 0 else None
    noise = None
    if finite(s["rel_mse_stderr"]) and finite(d["rel_mse_stderr"]) and finite(re_):
        noise = abs(s["rel_mse_mean"] - d["rel_mse_mean"]) < 2 * math.hypot(
            s["rel_mse_stderr"], d["rel_mse_stderr"])
    err = ratio_words(re_, "error") + (" (within 2 standard errors)" if noise else "")
    text = "%s: %s, %s at equal spp (%d)" % (head, time_words(rt, spread), err, n)
    eq = equal_time(default, setting)
    if len(setting) < 2:
        return text + "; one spp only (budget), so no equal-time comparison."
    if not eq:
        return text + "; no equal-time comparison (its measured times do not span any of the " \
                      "default's)."
    # At equal time a time difference within the timing noise is an error difference as large
    # (error ~ 1/time): such points decide nothing.
    tol = spread if finite(spread) else 0.0
    decisive = [(n_, q) for n_, q in eq if abs(q - 1.0) >= tol]
    tied = [n_ for n_, q in eq if abs(q - 1.0) < tol]
    span = "%d" % eq[0][0] if len(eq) == 1 else "%d–%d" % (eq[0][0], eq[-1][0])
    if not decisive:
        return text + "; at equal time (the default's %s spp) no difference beyond the timing " \
                      "noise." % span
    win = ["setting" if q < 1 else "default" for _, q in decisive]
    name = {"setting": "%s %s" % (knob["name"], value), "default": dl}
    if all(w == win[0] for w in win):
        n_, q = decisive[-1]
        text += "; at equal time (the default's %s spp) %s wins%s (%s at %d spp's time)" % (
            span, name[win[0]], "" if tied else " throughout", ratio_words(q, "error"), n_)
    else:
        first = next(i for i, w in enumerate(win) if w != win[0])
        text += "; at equal time, %s wins below %d spp and %s from there" % (
            name[win[0]], decisive[first][0], name[win[first]])
        if any(w != win[first] for w in win[first:]):
            text += " (the lead changes more than once: within noise)"
    if tied:
        text += "; a tie within the timing noise at %s spp" % ", ".join(str(t) for t in tied)
    return text + "."


def log_ticks(ax, ticker):
    """Labelled ticks at 1, 2, 5 x 10^k on both log axes, plain numbers, no minor ticks (log
    minor ticks cost seconds in tight_layout and leave a narrow range with one label)."""
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0), numticks=12))
        axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: "%g" % v))
        axis.set_minor_locator(ticker.NullLocator())


class Deadline:
    """When the charts must be done (None: no limit), and the slowest chart so far per panel.

    A chart's time grows with its panels (a device chart has one per knob, the spp chart one),
    so the next chart is predicted from the slowest seconds per panel so far, with a margin of
    half again and the report's own writing (a busy machine draws each chart slower than the
    last: predicting a 12-panel chart from the 1-panel spp chart's time overran the budget)."""

    MARGIN = 1.5     # predicted time, times this
    RESERVE = 0.5    # seconds kept for write_report and the exit

    def __init__(self, seconds):
        self.end = None if seconds is None else time.monotonic() + seconds
        self.per_panel = 0.0
        self.skipped = []

    def allows(self, name, panels=1):
        """True if a chart of `panels` panels still fits; else records name as skipped."""
        need = self.MARGIN * self.per_panel * panels + self.RESERVE
        if self.end is None or time.monotonic() + need < self.end:
            return True
        self.skipped.append(name)
        return False

    def took(self, t0, panels=1):
        """Records a chart of `panels` panels started at t0 (time.monotonic())."""
        self.per_panel = max(self.per_panel, (time.monotonic() - t0) / max(1, panels))


def draw_charts(study, outdir, plt, ticker, deadline):
    """Writes the spp chart and the per-device charts, in that order, as long as the deadline
    allows; returns the names of the files written."""
    points = study["points"]
    knobs = [k for k in study["knobs"] if k["name"] != "spp" and k["available"] and k["selected"]]
    files = [draw_spp_chart(study, outdir, plt, ticker, deadline)]
    for metric, tag, label in (("rel_mse", "", "relMSE"), ("ssim_error", "-ssim", "1 − SSIM")):
        for device in study["options"]["devices"]:
            shown = [k for k in knobs if any(curve(points, device, k["name"]))]
            if not shown:
                continue
            chart = "chart-%s%s.png" % (device, tag)
            if not deadline.allows(chart, len(shown)):
                continue
            t0 = time.monotonic()
            ncol = min(3, len(shown))
            nrow = math.ceil(len(shown) / ncol)
            fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow), squeeze=False)
            default = curve(points, device, "default")
            for ax, k in zip(axes.flat, shown):
                allpts = []
                series = [("%s (default)" % default_label(study, k), default, "black")]
                colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
                for i, v in enumerate(k["values"]):
                    c = curve(points, device, k["name"], v)
                    if c:
                        series.append((str(v), c, colours[i % len(colours)]))
                for name, c, col in series:
                    c = [p for p in c if finite(p[metric + "_mean"]) and p[metric + "_mean"] > 0
                         and finite(p["seconds_render"]) and p["seconds_render"] > 0]
                    if not c:
                        continue
                    xs = [p["seconds_render"] for p in c]
                    ys = [p[metric + "_mean"] for p in c]
                    err = [p[metric + "_stderr"] if finite(p[metric + "_stderr"]) else 0 for p in c]
                    ax.errorbar(xs, ys, yerr=err, color=col, marker="o", ms=3, lw=1.6 if
                                col == "black" else 1.1, capsize=2, label=name, zorder=3)
                    allpts += list(zip(xs, ys))
                front = pareto(allpts)
                if len(front) >= 2:
                    ax.plot(*zip(*front), color="tab:orange", lw=7, alpha=0.25, zorder=1,
                            solid_capstyle="round", label="Pareto front")
                ax.set_xscale("log")
                ax.set_yscale("log")
                log_ticks(ax, ticker)
                if allpts:
                    # Faint equal-error lines at the decades inside the data's range.
                    lo, hi = ax.get_ylim()
                    for dec in range(math.ceil(math.log10(lo)), math.floor(math.log10(hi)) + 1):
                        ax.axhline(10.0 ** dec, color="0.8", lw=0.7, zorder=0)
                    ax.set_ylim(lo, hi)
                ax.set_title("%s (%s)" % (k["name"], k["option"]) +
                             (", time knob" if k["kind"] == "time" else ""), fontsize=9)
                ax.set_xlabel("render time (s)", fontsize=8)
                ax.set_ylabel(label, fontsize=8)
                ax.tick_params(labelsize=7)
                ax.legend(fontsize=6, loc="best")
            for ax in list(axes.flat)[len(shown):]:
                ax.axis("off")
            fig.suptitle("%s on %s: %s against render time (%s spp, %d seeds; lower left is "
                         "better)" % (study["scene_name"], device, label,
                                      ",".join(str(s) for s in study["options"]["spp"]),
                                      study["options"]["seeds"]), fontsize=10)
            # Room for the title above the top row (tight_layout ignores suptitle).
            fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / (3.6 * nrow)))
            fig.savefig(os.path.join(outdir, chart), dpi=110)
            plt.close(fig)
            files.append(chart)
            deadline.took(t0, len(shown))
    return files


def draw_spp_chart(study, outdir, plt, ticker, deadline):
    """The default curve against spp with the fit relMSE = a / spp + c (always drawn)."""
    points = study["points"]
    t0 = time.monotonic()
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for device in study["options"]["devices"]:
        c = [p for p in curve(points, device, "default") if finite(p["rel_mse_mean"])
             and p["rel_mse_mean"] > 0]
        if not c:
            continue
        line = ax.errorbar([p["spp"] for p in c], [p["rel_mse_mean"] for p in c],
                           yerr=[p["rel_mse_stderr"] if finite(p["rel_mse_stderr"]) else 0
                                 for p in c], marker="o", ms=4, capsize=2, label=device)
        col = line[0].get_color()
        fit = study["fits"].get(device, {})
        if finite(fit.get("a")) and finite(fit.get("c")):
            top = math.log2(max(study["options"]["spp"]))
            s = [2 ** (top * i / 64) for i in range(65)]
            ax.plot(s, [fit["a"] / x + fit["c"] for x in s], "--", color=col, lw=1,
                    label="%s fit %.3g/spp + %.3g" % (device, fit["a"], fit["c"]))
            if fit["c"] > 0:
                ax.axhline(fit["c"], color=col, ls=":", lw=1)
                ax.annotate("c = %.3g" % fit["c"], (s[0], fit["c"]), fontsize=7, color=col,
                            va="bottom")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    log_ticks(ax, ticker)
    ax.xaxis.set_major_locator(ticker.LogLocator(base=2, numticks=20))
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("relMSE")
    ax.set_title("%s: default knobs, relMSE against spp" % study["scene_name"], fontsize=10)
    ax.grid(True, which="major", color="0.9")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "chart-spp.png"), dpi=110)
    plt.close(fig)
    deadline.took(t0)
    return "chart-spp.png"


def write_report(study, outdir, charts, skipped=()):
    """Writes report.md (skipped: charts left out for the time budget)."""
    points = study["points"]
    opt = study["options"]
    ref = study["reference"]
    m = study["machine"]
    lines = ["# basalt study: %s" % study["scene_name"], ""]
    lines.append("- Scene: `%s` (%dx%d)" % (study["scene"], study["width"], study["height"]))
    lines.append("- Machine: %s, %d cores; basalt %s" % (m["cpu"], m["cores"], m["basalt_commit"]))
    if ref.get("given"):
        lines.append("- Reference: `%s` (given)" % ref["path"])
    else:
        lines.append("- Reference: %d spp on %s, seed %d, default knobs%s: `%s`%s" % (
            ref["spp"], ref.get("device_name") or ref["device"], ref["seed"],
            ", cached" if ref.get("cached") else
            (", %.3g s" % ref["seconds_process"] if finite(ref.get("seconds_process")) else ""),
            os.path.basename(ref["path"]),
            " — **reduced to fit half the budget**: errors near 1/%d are the reference's own "
            "noise" % ref["spp"] if ref.get("reduced_for_budget") else ""))
    runs = study["runs"]
    budget = opt.get("budget_seconds")
    lines.append("- Sweep: spp %s; %d seeds per point; devices %s; %s; %d runs done, %d skipped "
                 "for the budget, %d failed, %.0f s in all" % (
                     ", ".join(str(s) for s in opt["spp"]), opt["seeds"], ", ".join(opt["devices"]),
                     "budget %.0f s" % budget if finite(budget) else "no budget",
                     runs["done"], runs["skipped"], runs["failed"], study["elapsed_seconds"]))
    for d in opt["devices"]:
        spread, idle, noise = time_spread(points, d), idle_deviations(study, d), \
            time_noise(study, d)
        if not finite(noise):
            continue
        parts = []
        if finite(spread):
            parts.append("render times of the default vary by ±%.0f %% (median sd over seeds)"
                         % (100 * spread))
        if idle:
            parts.append("the %d settings that leave this scene's image unchanged (same work) "
                         "differ from the default by a median %.0f %%, at most %.0f %%" % (
                             len(idle), 100 * idle[len(idle) // 2], 100 * idle[-1]))
        text = "- Timing noise on %s: %s" % (d, "; ".join(parts))
        lines.append(text + ". Time differences under %.0f %% are called the same." %
                     (100 * noise))
    lines += ["", "Errors are against the reference: **relMSE** as pbrt-v4's `imgtool diff "
              "--metric MRSE` (mean over pixels and RGB of (v − ref)² / (ref + 0.01)²), and "
              "the perceptual error **1 − SSIM** (Wang et al. 2004; 11×11 Gaussian window, "
              "σ = 1.5, on the luma of the sRGB image clamped to [0, 1]). Each point is the mean "
              "over its seeds (error bars: standard errors). Time is the render time the run "
              "reports (`seconds_render`), unless it says process time (the whole child process, "
              "start-up and pipeline compile included).", ""]
    cmp = study.get("compare")
    if cmp:
        lines += ["## Equal-error comparison with %s" % cmp["name"], ""]
        lines.append("`%s`: relMSE %s, 1 − SSIM %s, %.3g s." % (
            cmp["image"], fmt(cmp["rel_mse"]), fmt(cmp["ssim_error"]), cmp["seconds"]))
        lines.append("")
        for d in cmp["devices"]:
            lines.append("- " + d["sentence"])
        lines += ["", "(basalt's time is the whole process, start-up included, read off its "
                  "default curve by log-log interpolation, or from the fit a/spp + c beyond it.)",
                  ""]
    if charts is None:
        lines += ["**No charts**: matplotlib is missing (install python3-matplotlib).", ""]
    if skipped:
        lines += ["**Charts left out for the time budget**: %s." % ", ".join(skipped), ""]
    # Samples per pixel.
    lines += ["## spp (samples per pixel, the x-axis of every curve)", ""]
    if charts:
        lines += ["![relMSE against spp](chart-spp.png)", ""]
    for device in opt["devices"]:
        c = curve(points, device, "default")
        fit = study["fits"].get(device, {})
        dn = c[0].get("device_name") if c else ""
        lines.append("**%s**%s: default knobs" % (device, " (%s)" % dn if dn and dn != device
                                                  else ""))
        lines += ["", "| spp | render s | process s | relMSE | 1 − SSIM |",
                  "|---|---|---|---|---|"]
        for p in c:
            lines.append("| %d | %s | %s | %s ± %s | %s ± %s |" % (
                p["spp"], fmt(p["seconds_render"]), fmt(p["seconds_process"]),
                fmt(p["rel_mse_mean"]), fmt(p["rel_mse_stderr"], "%.2g"),
                fmt(p["ssim_error_mean"]), fmt(p["ssim_error_stderr"], "%.2g")))
        if finite(fit.get("a")):
            text = "Fit relMSE ≈ a/spp + c: a = %.3g, c = %.3g" % (fit["a"], fit["c"])
            text += ": no floor measurable" if fit["c"] <= 0 else \
                ": the floor more samples cannot remove"
            nref = ref.get("spp")
            if nref and fit["c"] > 0 and abs(fit["c"] - fit["a"] / nref) < 0.5 * fit["a"] / nref:
                text += " — here about a/%d, the %d-spp reference's own noise, not a bias" % (
                    nref, nref)
            elif fit["c"] > 0:
                text += " (a bias against the reference, or the reference's own noise)"
            lines += ["", text + "."]
        lines.append("")
    if charts:
        lines += ["## Charts", ""]
        for device in opt["devices"]:
            for tag, what in (("", "relMSE"), ("-ssim", "1 − SSIM")):
                name = "chart-%s%s.png" % (device, tag)
                if name in charts:
                    lines += ["![%s on %s](%s)" % (what, device, name), ""]
    lines += ["## Knobs", ""]
    for k in study["knobs"]:
        if k["name"] == "spp":
            continue
        lines += ["### %s (`%s`, %s knob; default %s)" % (
            k["name"], k["option"], k["kind"], default_label(study, k)), ""]
        if not k["available"]:
            lines += ["Not available in this build (`%s` is not in `basalt --help`)." %
                      k["option"], ""]
            continue
        if not k["selected"]:
            lines += ["Not swept (left out by `--knobs`).", ""]
            continue
        for device in opt["devices"]:
            default = curve(points, device, "default")
            spread = time_noise(study, device)
            rows, sentences = [], []
            for v in k["values"]:
                if v == k["default"]:
                    continue
                setting = curve(points, device, k["name"], v)
                tried = [p for p in points if p["device"] == device and p["knob"] == k["name"]
                         and p["value"] == v]
                if not setting:
                    why = next((p["failure"] for p in tried if p["failed"]), "")
                    rows.append([v, "failed: " + why.replace("|", "/").replace("\n", " ")[:120]
                                 if why else "skipped (budget)"])
                    continue
                n = common_spp(default, setting)
                d, s = (at_spp(default, n), at_spp(setting, n)) if n else (None, None)

                def rel(key):
                    """Setting over default at the common spp, as a table ratio."""
                    ok = n and finite(s[key]) and finite(d[key]) and d[key] > 0
                    return fmt_ratio(s[key] / d[key]) if ok else "–"
                if k["kind"] == "time":
                    rows.append([v, n or "–", rel("seconds_render"), rel("seconds_process"),
                                 fmt(s.get("max_abs_diff_vs_default")) if n else "–"])
                else:
                    eq = equal_time(default, setting)
                    last = eq[-1] if eq else None
                    diffs = [p["max_abs_diff_vs_default"] for p in setting
                             if finite(p.get("max_abs_diff_vs_default"))]
                    rows.append([v, n or "–", rel("seconds_render"), rel("rel_mse_mean"),
                                 rel("ssim_error_mean"),
                                 fmt_ratio(last[1]) + " (at %d spp's time)" % last[0]
                                 if last else "–", fmt(max(diffs)) if diffs else "–"])
                sentences.append(sentence(study, k, v, default, setting, spread))
            lines.append("**%s**" % device)
            lines.append("")
            if k["kind"] == "time":
                lines += ["| setting | at spp | render time vs default | process time vs default "
                          "| max abs diff vs default |", "|---|---|---|---|---|"]
            else:
                lines += ["| setting | at spp | time vs default | relMSE vs default (equal spp) | "
                          "1 − SSIM vs default (equal spp) | relMSE vs default (equal time) | "
                          "max abs diff vs default |", "|---|---|---|---|---|---|---|"]
            ncol = 5 if k["kind"] == "time" else 7
            lines += ["| " + " | ".join(str(c) for c in r + [""] * (ncol - len(r))) + " |"
                      for r in rows]
            lines.append("")
            lines += ["- " + s for s in sentences]
            lines.append("")
    failed = [p for p in points if p["failed"]]
    if failed:
        lines += ["## Failed points", ""]
        for p in failed:
            lines.append("- %s %s on %s at %d spp: %s" % (
                p["knob"], p["value"], p["device"], p["spp"],
                p["failure"].replace("\n", " ")[:300]))
        lines.append("")
    skipped = [p for p in points if p["skipped"]]
    if skipped:
        lines += ["## Skipped for the budget", ""]
        by = {}
        for p in skipped:
            by.setdefault((p["device"], p["spp"]), []).append(
                "default" if p["knob"] == "default" else "%s=%s" % (p["knob"], p["value"]))
        total = len({(p["knob"], p["value"]) for p in points if p["knob"] != "default"})
        for (dev, spp), names in sorted(by.items()):
            knobs_only = [n for n in names if n != "default"]
            if total and len(knobs_only) == total:
                names = [n for n in names if n == "default"] + ["all %d knob settings" % total]
            lines.append("- %s, %d spp: %s" % (dev, spp, ", ".join(names)))
        lines.append("")
    path = os.path.join(outdir, "report.md")
    with open(path + ".tmp", "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    os.replace(path + ".tmp", path)


def main():
    """Reads study.json and writes the charts and report.md beside it."""
    seconds = None
    if len(sys.argv) == 4 and sys.argv[2] == "--seconds":
        seconds = float(sys.argv[3])
    elif len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    with open(sys.argv[1], encoding="utf-8") as f:
        study = json.load(f)
    outdir = os.path.dirname(os.path.abspath(sys.argv[1]))
    deadline = Deadline(seconds)  # before matplotlib's import, which is part of the time
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker as ticker
    except ImportError:
        write_report(study, outdir, None)
        print("study_report.py: matplotlib is missing (install python3-matplotlib): "
              "report.md has no charts", file=sys.stderr)
        return EXIT_NO_MATPLOTLIB
    charts = draw_charts(study, outdir, plt, ticker, deadline)
    write_report(study, outdir, charts, deadline.skipped)
    return 0


if __name__ == "__main__":
    sys.exit(main())
