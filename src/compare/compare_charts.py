#!/usr/bin/python3
"""compare_charts.py: the two charts of `nimbus compare`, drawn with matplotlib (Agg, headless).

    /usr/bin/python3 compare_charts.py DIR [--title NAME] [--reference-noise RELMSE]
                                           [--wkb SOURCE/KERNEL] [--describe]

Reads what `nimbus compare` wrote in DIR (src/compare/Compare.cpp, docs/validation.md):
  compare.csv                  every run and seed (src/compare/Report.cpp)
  panels/reference.png         the reference, WKB at the scene's own model and the path tracer at
  panels/wkb.png               WKB's time, each through the preview transform (8-bit sRGB)
  panels/pathtrace.png
  panels/vrl.png               (optional) virtual ray lights at WKB's time: a fourth image panel
  panels/difference.exr        signed luminance WKB - reference, one float channel Y, linear
                               radiance W/(m^2 sr) (Rec. 709 weights), as the film stores it
and writes
  error_vs_time.png            log-log beauty relMSE against render time: the path tracer's
                               seed mean per time step (each seed a faint dot), WKB's source
                               models x kernels and its quality ladder as points, single, the
                               path tracer at WKB's time, virtual ray lights' seed mean per
                               time step and at WKB's time, the reference's own noise as a dashed
                               floor (--reference-noise, omitted when 0), a legend
  sheet.png                    the four (five with vrl) panels with titles, the difference in a diverging map
                               symmetric about 0 at the largest |difference|, with its colour bar

--title names the scene in the chart's title; --wkb is the model the sheet's WKB panel shows
(its time and error are read from the CSV's "base" row of that model). --describe prints, as
JSON on stdout, what the figures hold, read back from the matplotlib objects (titles, axis
labels, legend entries, panel titles, the colour bar's label and range, the PNGs' pixel sizes).

Run by `nimbus compare` after compare.csv (Compare.cpp, drawCompareCharts); exit status 0, or 1
with one line "compare_charts.py: error: ..." on stderr. Needs Debian's python3-matplotlib
and python3-openimageio (the EXR); scripts/install-deps.sh installs both.
"""

import argparse
import csv
import json
import os
import sys

PROG = "compare_charts.py"

# Chart and sheet sizes, in inches at DPI: deterministic pixel sizes (no tight bounding box).
DPI = 100
CHART_SIZE = (9.6, 5.6)
SHEET_PANEL_INCHES = 3.2

# One colour per WKB source model x kernel (the hand-drawn chart's colours, kept for continuity).
WKB_COLOURS = {
    "straight/gaussian": "#e6730d",
    "straight/exact": "#cc1a1a",
    "random_walk/gaussian": "#1a9933",
    "random_walk/exact": "#8c33b3",
}
PT_COLOUR = "#1f59cc"
VRL_COLOUR = "#2a9d3a"


class ChartError(Exception):
    pass


def read_rows(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        raise ChartError(f"cannot read {path}: {e.strerror}")
    need = {"method", "label", "source", "kernel", "seed", "seconds", "beauty_relmse"}
    if not rows or not need <= set(rows[0]):
        raise ChartError(f"{path}: no rows, or not a compare.csv (needs columns {', '.join(sorted(need))})")
    for r in rows:
        try:
            r["seconds"] = float(r["seconds"])
            r["beauty_relmse"] = float(r["beauty_relmse"])
        except ValueError:
            raise ChartError(f"{path}: a row with a non-numeric seconds or beauty_relmse: {r}")
    return rows


def positive(rows):
    """The rows that a log-log chart can place (relMSE 0 is a reference against itself)."""
    return [r for r in rows if r["seconds"] > 0 and r["beauty_relmse"] > 0]


def draw_chart(plt, rows, title, noise, path):
    fig, ax = plt.subplots(figsize=CHART_SIZE, dpi=DPI, constrained_layout=True)
    ax.set_xscale("log")
    ax.set_yscale("log")

    pt = positive([r for r in rows if r["method"] == "pathtrace" and r["label"].startswith("t=")])
    if pt:
        ax.scatter([r["seconds"] for r in pt], [r["beauty_relmse"] for r in pt], s=10, color=PT_COLOUR,
                   alpha=0.35, linewidths=0, label="path tracer, each seed")
        steps = {}
        for r in pt:
            steps.setdefault(r["label"], []).append(r)
        mean = sorted((sum(r["seconds"] for r in g) / len(g), sum(r["beauty_relmse"] for r in g) / len(g), len(g))
                      for g in steps.values())
        seeds = max(m[2] for m in mean)
        ax.plot([m[0] for m in mean], [m[1] for m in mean], "-o", color=PT_COLOUR, lw=2, ms=5,
                label=f"path tracer, mean of {seeds} seed{'s' if seeds != 1 else ''}")
    eq = positive([r for r in rows if r["method"] == "pathtrace" and r["label"] == "equal-time"])
    if eq:
        ax.scatter([r["seconds"] for r in eq], [r["beauty_relmse"] for r in eq], s=60, marker="D",
                   facecolors="none", edgecolors=PT_COLOUR, linewidths=1.5, label="path tracer at WKB's time")
    vrl = positive([r for r in rows if r["method"] == "vrl" and r["label"].startswith("t=")])
    if vrl:
        steps = {}
        for r in vrl:
            steps.setdefault(r["label"], []).append(r)
        mean = sorted((sum(r["seconds"] for r in g) / len(g), sum(r["beauty_relmse"] for r in g) / len(g), len(g))
                      for g in steps.values())
        seeds = max(m[2] for m in mean)
        ax.plot([m[0] for m in mean], [m[1] for m in mean], "-o", color=VRL_COLOUR, lw=2, ms=5,
                label=f"virtual ray lights, mean of {seeds} seed{'s' if seeds != 1 else ''}")
    eqv = positive([r for r in rows if r["method"] == "vrl" and r["label"] == "equal-time"])
    if eqv:
        ax.scatter([r["seconds"] for r in eqv], [r["beauty_relmse"] for r in eqv], s=60, marker="D",
                   facecolors="none", edgecolors=VRL_COLOUR, linewidths=1.5, label="virtual ray lights at WKB's time")

    wkb = [r for r in rows if r["method"] == "wkb"]
    for model, colour in WKB_COLOURS.items():
        base = positive([r for r in wkb if r["label"] == "base" and f"{r['source']}/{r['kernel']}" == model])
        if base:
            ax.scatter([r["seconds"] for r in base], [r["beauty_relmse"] for r in base], s=70, color=colour,
                       edgecolors="black", linewidths=0.5, zorder=3, label=f"WKB {model}")
    ladder = positive([r for r in wkb if r["label"] != "base"])
    if ladder:
        models = sorted({f"{r['source']}/{r['kernel']}" for r in ladder})
        colour = WKB_COLOURS.get(models[0], "0.3") if len(models) == 1 else "0.3"
        ax.scatter([r["seconds"] for r in ladder], [r["beauty_relmse"] for r in ladder], s=55, marker="s",
                   facecolors="none", edgecolors=colour, linewidths=1.5, zorder=3,
                   label=f"WKB {', '.join(models)} quality ladder")
        for r in ladder:
            ax.annotate(r["label"], (r["seconds"], r["beauty_relmse"]), textcoords="offset points", xytext=(6, 4),
                        fontsize=8, color="0.25")
    single = positive([r for r in rows if r["method"] == "single"])
    if single:
        ax.scatter([r["seconds"] for r in single], [r["beauty_relmse"] for r in single], s=60, marker="^",
                   color="0.35", zorder=3, label="single (L0 + L1 only)")
    if noise > 0:
        ax.axhline(noise, color="black", ls="--", lw=1, label=f"reference noise floor ({noise:.2g})")

    if not ax.has_data():
        raise ChartError("compare.csv has no row with a positive time and beauty relMSE to chart")
    ax.set_title(f"{title}: beauty error against render time")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("beauty relMSE")
    ax.grid(True, which="major", color="0.8", lw=0.8)
    ax.grid(True, which="minor", color="0.92", lw=0.5)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=9, frameon=False)
    save(fig, path)
    described = {
        "path": path,
        "title": ax.get_title(),
        "xlabel": ax.get_xlabel(),
        "ylabel": ax.get_ylabel(),
        "xscale": ax.get_xscale(),
        "yscale": ax.get_yscale(),
        "legend": [t.get_text() for t in ax.get_legend().get_texts()],
    }
    plt.close(fig)
    return described


def read_image(path, channels):
    """An image as a float numpy array (h, w, channels) through OpenImageIO."""
    try:
        import OpenImageIO as oiio
    except ImportError:
        raise ChartError("reading the panels needs OpenImageIO's Python module (Debian: python3-openimageio)")
    buf = oiio.ImageBuf(path)
    if buf.has_error:
        raise ChartError(f"cannot read {path}: {buf.geterror().strip()}")
    pixels = buf.get_pixels(oiio.FLOAT)
    if pixels is None or pixels.ndim != 3 or pixels.shape[2] < channels:
        raise ChartError(f"{path}: expected an image with at least {channels} channel(s)")
    return pixels[:, :, :channels]


def run_row(rows, method, label, model=None):
    for r in rows:
        if r["method"] == method and r["label"] == label and (model is None or f"{r['source']}/{r['kernel']}" == model):
            return r
    return None


def caption(name, row):
    if row is None:
        return name
    return f"{name}\n{row['seconds']:.2f} s, beauty relMSE {row['beauty_relmse']:.3g}"


def draw_sheet(plt, rows, panels_dir, wkb_model, path):
    names = ["reference", "wkb", "pathtrace"]
    # The vrl panel (virtual ray lights at WKB's time) where compare rendered one.
    if os.path.exists(os.path.join(panels_dir, "vrl.png")):
        names.append("vrl")
    images = [read_image(os.path.join(panels_dir, n + ".png"), 3) for n in names]
    diff = read_image(os.path.join(panels_dir, "difference.exr"), 1)[:, :, 0]
    h, w = diff.shape
    if any(im.shape[:2] != (h, w) for im in images):
        raise ChartError(f"the panels in {panels_dir} differ in size")

    peak = float(abs(diff).max())
    scale = peak if peak > 0 else 1.0
    wkb_name = f"WKB {wkb_model}" if wkb_model else "WKB"
    titles = [
        "reference\n(path tracer, converged)",
        caption(wkb_name, run_row(rows, "wkb", "base", wkb_model) if wkb_model else None),
        caption("path tracer at WKB's time", run_row(rows, "pathtrace", "equal-time")),
    ]
    if "vrl" in names:
        titles.append(caption("virtual ray lights at WKB's time", run_row(rows, "vrl", "equal-time")))
    titles.append("WKB \u2212 reference, luminance\n(red brighter, blue darker)")
    n = len(titles)
    panel_h = SHEET_PANEL_INCHES * h / w
    fig, axes = plt.subplots(1, n, figsize=(n * SHEET_PANEL_INCHES + 1.2, panel_h + 1.1), dpi=DPI,
                             constrained_layout=True)
    for ax, im, t in zip(axes[:n - 1], images, titles):
        ax.imshow(im.clip(0.0, 1.0), interpolation="nearest")
    shown = axes[n - 1].imshow(diff, cmap="RdBu_r", vmin=-scale, vmax=scale, interpolation="nearest")
    for ax, t in zip(axes, titles):
        ax.set_title(t, fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
    bar = fig.colorbar(shown, ax=axes[n - 1], fraction=0.08, pad=0.03)
    bar.set_label("\u0394Y = Y(WKB) \u2212 Y(reference)\nlinear radiance, W/(m\u00b2 sr)", fontsize=9)
    save(fig, path)
    described = {
        "path": path,
        "panels": [ax.get_title() for ax in axes],
        "colorbar": bar.ax.get_ylabel(),
        "colorbar_range": [float(v) for v in shown.get_clim()],
        "difference_peak": peak,
    }
    plt.close(fig)
    return described


def save(fig, path):
    """Written whole or not at all, as nimbus's other outputs: a temporary file renamed over path."""
    tmp = os.path.join(os.path.dirname(path) or ".", "." + os.path.basename(path) + ".tmp.png")
    try:
        fig.savefig(tmp, dpi=DPI)
        os.replace(tmp, path)
    except OSError as e:
        raise ChartError(f"cannot write {path}: {e.strerror}")
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def png_size(path):
    """(width, height) from a PNG's IHDR."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise ChartError(f"{path} is not a PNG")
    return [int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")]


def main(argv):
    ap = argparse.ArgumentParser(prog=PROG, description="The charts of nimbus compare, from its output directory.")
    ap.add_argument("dir", help="the directory nimbus compare wrote (compare.csv, panels/)")
    ap.add_argument("--title", default="nimbus compare", help="the scene's name, for the chart's title")
    ap.add_argument("--reference-noise", type=float, default=0.0,
                    help="the reference's own beauty relMSE, drawn as the noise floor (0: none)")
    ap.add_argument("--wkb", default="", help="SOURCE/KERNEL of the sheet's WKB panel")
    ap.add_argument("--describe", action="store_true", help="print what the figures hold as JSON")
    args = ap.parse_args(argv)

    rows = read_rows(os.path.join(args.dir, "compare.csv"))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ChartError("needs matplotlib (Debian: apt-get install python3-matplotlib; scripts/install-deps.sh)")
    chart = draw_chart(plt, rows, args.title, args.reference_noise, os.path.join(args.dir, "error_vs_time.png"))
    sheet = draw_sheet(plt, rows, os.path.join(args.dir, "panels"), args.wkb, os.path.join(args.dir, "sheet.png"))
    if args.describe:
        for d in (chart, sheet):
            d["size"] = png_size(d["path"])
        json.dump({"error_vs_time": chart, "sheet": sheet}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except ChartError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        sys.exit(1)
