"""docs/fit_measured.md: `twoscale fit` on the shared measured files, each fit judged by its render against the file's.

The files (the shared data's README): the 50 MERL materials of merl-nbrdf/ (published NBRDF networks written as MERL
files by runtimes/testing/nbrdf.py: stand-ins for the measurements, smoother at the sharpest peaks) and the 14 RGL files
of rgl/. Each set is split in two, in the order of the names: the even places choose (the loss, the samples, the starts
and --model auto's rule were chosen on them: docs/fit.md "The loss"), the odd places check. Both halves are reported.

For each file:
  - `twoscale fit FILE --json` (--model auto, the default), timed: the seconds a user waits;
  - `twoscale fit FILE --compare --json`, timed: the same two-scale fits (the same samples) beside the seven comparison
    models (ggx_lambert, beckmann_lambert, epd_lambert, low_smooth, abc, sgd, he) and, for a MERL material, the
    published ABC and SGD fits at their authors' parameters, each with its render's SMAPE (pipeline/fit/src/render.rs).
Writes --out (docs/fit_measured.md): the summary per half against the targets, the table per material, a figure of
SMAPE per material (docs/renders/fit_measured_smape.png, matplotlib) and a grid of sphere renders, the file's over the
written fit's, for eight materials of different kinds (docs/renders/fit_measured_spheres.png, from `--render`).

    .venv/bin/python -m examples.fit.measured [--data DIR] [--tables tables-out] [--work DIR] [--out docs/fit_measured.md] [--reuse]

Needs the default preset's general tables (`make tables`) and the twoscale binary (target/release, or $TWOSCALE_BIN).
On 2 cores it takes about 40 minutes (64 files, each fitted twice).
"""
import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import matplotlib
import merl
import nbrdf
import numpy as np
from shared_data import shared_data
from twoscale_c import twoscale_binary

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after the backend)

REPO = Path(__file__).resolve().parents[2]
COMPARISON = ("ggx_lambert", "beckmann_lambert", "epd_lambert")
CLOSED_FORMS = ("low_smooth", "abc", "sgd", "he")
PUBLISHED = ("abc_published", "sgd_published")
# Eight materials of different kinds for the grid of renders: a metal, a metallic paint, a plastic, a paint, a wood,
# a fabric (MERL), a metallic laminate and a satin (RGL).
SHOWN = ("steel", "gold-metallic-paint3", "maroon-plastic", "white-paint", "fruitwood-241", "blue-fabric",
         "ilm_l3_37_metallic_rgb", "satin_rosaline_rgb")


def files(data, work):
    """[(name, path, kind, half)]: the MERL stand-ins (written into work/merl once) and the RGL files, each set split
    in two by the place of its name (even: choose, odd: check)."""
    merl_dir = work / "merl"
    merl_dir.mkdir(parents=True, exist_ok=True)
    out = []
    nets = sorted((data / "merl-nbrdf").glob("*.h5"))
    for k, h5 in enumerate(nets):
        path = merl_dir / f"{h5.stem}.binary"
        if not path.exists():
            merl.write(path, nbrdf.to_merl(nbrdf.load(h5)))
        out.append((h5.stem, path, "MERL", "choose" if k % 2 == 0 else "check"))
    for k, path in enumerate(sorted((data / "rgl").glob("*.bsdf"))):
        out.append((path.stem, path, "RGL", "choose" if k % 2 == 0 else "check"))
    return out


def fit(path, tables, out_dir, *args):
    """`twoscale fit PATH ... --json --quiet`: (its JSON, the wall time)."""
    cmd = [twoscale_binary(), "fit", str(path), "--out", str(out_dir / f"{path.stem}.toml"), "--tables", str(tables),
           "--json", "--quiet", *args]
    start = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {res.stderr.strip()}")
    return json.loads(res.stdout), time.perf_counter() - start


def summary(rows, kind, half):
    """The half's figures against the targets (docs/fit.md)."""
    rs = [r for r in rows if r["kind"] == kind and half in (r["half"], "both")]
    seconds = [r["seconds"] for r in rs]
    line = f"| {kind} | {half} | {len(rs)} | "
    if kind == "MERL":
        ratios = [r["smape"] / r["abc_published"] for r in rs]
        sgd = sum(r["smape"] <= r["sgd_published"] for r in rs)
        line += (f"{sum(x <= 1.0 for x in ratios)} of {len(rs)} | {sum(x <= 1.5 for x in ratios)} of {len(rs)} | "
                 f"{statistics.median(ratios):.2f} | {sgd} of {len(rs)} | ")
    else:
        beaten = sum(r["smape"] <= min(r[m] for m in COMPARISON) for r in rs)
        line += f"{beaten} of {len(rs)} (the best microfacet comparison model) | | | | "
    every = sum(r["smape"] <= min(r[m] for m in COMPARISON + CLOSED_FORMS) for r in rs)
    ratios = [r["compare_seconds"] / r["seconds"] for r in rs]
    return line + (f"{every} of {len(rs)} | {statistics.median(seconds):.1f} | {max(seconds):.1f} | "
                   f"{statistics.median(ratios):.1f} / {max(ratios):.1f} |")


def figure(rows, path):
    """SMAPE per material, sorted by the written fit's, one line per model; MERL and RGL side by side."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6), gridspec_kw={"width_ratios": [50, 14]})
    styles = {"smape": ("twoscale (written)", "k", "o"), "abc_published": ("ABC (published)", "tab:red", "s"),
              "sgd_published": ("SGD (published)", "tab:orange", "^"), "ggx_lambert": ("GGX + Lambert", "tab:blue", "."),
              "beckmann_lambert": ("Beckmann + Lambert", "tab:green", "."), "epd_lambert": ("EPD + Lambert", "tab:purple", "."),
              "low_smooth": ("Löw smooth (fitted)", "tab:brown", "x"), "abc": ("ABC (fitted)", "tab:pink", "x"),
              "sgd": ("SGD (fitted)", "tab:olive", "x"), "he": ("He et al. (fitted)", "tab:cyan", "x")}
    for ax, kind in zip(axes, ("MERL", "RGL")):
        rs = sorted((r for r in rows if r["kind"] == kind), key=lambda r: r["smape"])
        x = np.arange(len(rs))
        for key, (label, colour, marker) in styles.items():
            if all(key in r for r in rs):
                ax.plot(x, [r[key] for r in rs], marker=marker, color=colour, label=label, lw=1.4 if key == "smape" else 0.8)
        ax.set_yscale("log")
        ax.set_xticks(x, [r["name"].removesuffix("_rgb") for r in rs], rotation=90, fontsize=6)
        ax.set_title(f"{kind}: {len(rs)} files, by the fit's SMAPE", fontsize=9)
        ax.set_ylabel("render SMAPE")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def grid(pictures, path):
    """The renders (file | fit) of `pictures` [(name, array)] in two columns, each labelled."""
    fig, axes = plt.subplots(len(pictures) // 2, 2, figsize=(8, 1.1 * len(pictures)))
    for ax, (name, image) in zip(axes.flat, pictures):
        ax.imshow(image)
        ax.set_title(f"{name}: the file | the fit", fontsize=8)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, help="the shared data (default: runtimes/testing/shared_data.py's)")
    ap.add_argument("--tables", type=Path, default=REPO / "tables-out")
    ap.add_argument("--work", type=Path, default=REPO / "target/tmp/fit-measured")
    ap.add_argument("--out", type=Path, default=REPO / "docs/fit_measured.md")
    ap.add_argument("--reuse", action="store_true",
                    help="take each file's row from an earlier run (WORK/rows/NAME.json) where there is one: to redraw, or to "
                         "finish a run that stopped (the binary must be the same)")
    args = ap.parse_args()
    data = args.data or shared_data()
    (args.work / "fits").mkdir(parents=True, exist_ok=True)
    renders = REPO / "docs/renders"
    rows = []
    (args.work / "rows").mkdir(exist_ok=True)
    for name, path, kind, half in files(data, args.work):
        kept = args.work / "rows" / f"{name}.json"
        if args.reuse and kept.exists():
            rows.append(json.loads(kept.read_text()))
            continue
        auto, wall = fit(path, args.tables, args.work / "fits")
        png = args.work / "fits" / f"{name}.png"
        compared, compare_wall = fit(path, args.tables, args.work / "fits", "--compare", "--render", str(png))
        if compared["model"] != auto["model"] or compared["render_smape"] != auto["render_smape"]:
            raise RuntimeError(f"{name}: --compare wrote another fit than --model auto ({compared['model']}, {auto['model']})")
        by = {r["model"]: r["render_smape"] for r in compared["comparison"]}
        row = {"name": name, "kind": kind, "half": half, "model": auto["model"], "smape": auto["render_smape"],
               "log_rms": auto["error"]["log_rms"], "seconds": wall, "compare_seconds": compare_wall,
               "at_bounds": [a["name"] for a in auto["at_bounds"]], **{m: by[m] for m in COMPARISON + CLOSED_FORMS + PUBLISHED if m in by}}
        rows.append(row)
        kept.write_text(json.dumps(row))
        print(f"{name}: {row['model']} SMAPE {row['smape']:.3f}" + (f" (ABC {row['abc_published']:.3f})" if "abc_published" in row else "")
              + f", {wall:.1f} s", file=sys.stderr)

    figure(rows, renders / "fit_measured_smape.png")
    grid([(n.removesuffix("_rgb"), plt.imread(args.work / "fits" / f"{n}.png")) for n in SHOWN], renders / "fit_measured_spheres.png")
    lines = [
        "# `twoscale fit` on measured files: each fit rendered against the file",
        "",
        "Generated by `examples/fit/measured.py` (do not edit): every file of the shared data fitted with `twoscale fit` (--model auto)",
        "and with `--compare`, each fit rendered on the sphere of [fit.md](fit.md#the-render) against the file's own render, SMAPE",
        "between them. The MERL files are the published NBRDF networks of the real measurements written as MERL files",
        "(`runtimes/testing/nbrdf.py`): stand-ins, smoother than the measurements at the sharpest peaks. ABC and SGD are the published",
        "fits of the real measurements, at their authors' parameters. Each set is split in the order of the names: the even places",
        "chose the loss and `--model auto`'s rule (fit.md, \"The loss\"), the odd places check them. ABC and SGD are also fitted",
        "beside the others (`abc`, `sgd`, on the same samples and loss), with Löw et al.'s smooth-surface model and He et al.'s.",
        "Seconds: `--model auto`, wall time on this machine (2 cores); `--compare` / auto: the median and largest ratio of",
        "`--compare`'s wall time (with `--render`) to auto's.",
        "",
        "| set | half | files | at or below ABC (published) | within 1.5 x ABC | median SMAPE / ABC's | at or below SGD (published) "
        "| at or below every comparison model | median seconds | most seconds | `--compare` / auto |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [summary(rows, kind, half) for kind in ("MERL", "RGL") for half in ("choose", "check", "both")]
    lines += ["", "![SMAPE per material](renders/fit_measured_smape.png)", "",
              "![The file (left) and the written fit (right)](renders/fit_measured_spheres.png)", "",
              "| material | half | model written | at a bound | log RMS | SMAPE | ggx_lambert | beckmann_lambert | epd_lambert "
              "| low_smooth | abc | sgd | he | ABC (published) | SGD (published) | SMAPE / ABC's | seconds | `--compare` seconds |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        pub = [f"{r[m]:.3f}" if m in r else "" for m in PUBLISHED]
        ratio = f"{r['smape'] / r['abc_published']:.2f}" if "abc_published" in r else ""
        lines.append(f"| {r['name']} | {r['half']} | {r['model']} | {', '.join(r['at_bounds'])} | {r['log_rms']:.3f} | {r['smape']:.3f} | "
                     + " | ".join(f"{r[m]:.3f}" for m in COMPARISON + CLOSED_FORMS)
                     + f" | {' | '.join(pub)} | {ratio} | {r['seconds']:.1f} | {r['compare_seconds']:.1f} |")
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
