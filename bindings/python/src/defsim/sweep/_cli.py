# SPDX-License-Identifier: MIT
"""defsim-sweep: the command line of defsim.sweep."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

USAGE_EXAMPLES = """examples:
  defsim-sweep tests/scenes/cantilever.json --out study --workers 2 \\
      --grid bodies.0.material.youngs_modulus=1e5,1e6,1e7 --grid world.h=4e-4,8e-4 --plot
  defsim-sweep scene.json --out mc --samples 100 --seed 1 \\
      --range bodies.0.material.youngs_modulus=1e5,1e7,log --scheduler tcp://host:8786
  defsim-sweep --tool stress --out stress_sweep --workers 2 -- --reduced --backends symplectic_euler
  defsim-sweep --tool bench --out wp_sweep --workers 2 -- tests/scenes/rope.json --out bench_rope
"""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="defsim-sweep", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run variants of a defsim scene (or the runs of `defsim stress`) on Dask: "
                    "an embedded local cluster, or a scheduler. Rows go to DIR/results/*.parquet "
                    "as they finish.", epilog=USAGE_EXAMPLES)
    p.add_argument("scene", nargs="?", help="scene file (not with --tool)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="a swept key and its values (JSON or text); repeat for a product")
    p.add_argument("--variants", metavar="FILE", help="explicit variants: JSON lines, one "
                   "object of overrides per line ({\"world.h\": 1e-3, ...})")
    p.add_argument("--samples", type=int, metavar="N", help="N random variants over --range")
    p.add_argument("--range", action="append", default=[], metavar="KEY=LO,HI[,log|int]",
                   help="a sampled key: uniform, log-uniform or integer in [LO, HI]")
    p.add_argument("--seed", type=int, default=0, help="seed of --samples (default 0)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler (tcp://HOST:8786)")
    where.add_argument("--workers", type=int, metavar="N",
                       help="local cluster of N worker processes (default: the CPU count)")
    p.add_argument("--resume", action="store_true", help="skip variants DIR already holds")
    p.add_argument("--plot", action="store_true",
                   help="heat map of --plot-value over the first two swept keys: DIR/sweep.png")
    p.add_argument("--plot-value", default="status", metavar="COLUMN",
                   help="what the heat map shows: status (default) or a numeric column")
    p.add_argument("--keep-output", action="store_true",
                   help="keep each variant's folder (DIR/runs/<id>)")
    p.add_argument("--threads", type=int, default=1, help="world.threads of each variant")
    p.add_argument("--timeout", type=float, default=3600.0,
                   help="seconds before a variant is killed (default 3600)")
    p.add_argument("--exe", help="the defsim executable (default: $DEFSIM_EXE, the one the "
                   "installed package carries, PATH, build/)")
    p.add_argument("--tool", choices=["stress", "bench"],
                   help="spread the runs of `defsim TOOL` instead; its arguments follow --")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def _ranges(args: Sequence[str]) -> Dict[str, Any]:
    out: Dict[str, Any] = {}
    for a in args:
        key, sep, rest = a.partition("=")
        parts = rest.split(",")
        if not sep or len(parts) not in (2, 3):
            raise ValueError(f"--range {a!r}: expected KEY=LO,HI or KEY=LO,HI,log")
        out[key] = (float(parts[0]), float(parts[1]), *parts[2:])
    return out


def build_variants(ns: argparse.Namespace) -> List[Dict[str, Any]]:
    """The variants the arguments describe: the grid's product, times the samples if any, plus
    the listed ones."""
    from ._variants import grid, parse_grid_arg, samples
    axes = dict(parse_grid_arg(g) for g in ns.grid)
    variants = grid(axes) if axes else [{}]
    if ns.samples is not None:
        ranges = _ranges(ns.range)
        if not ranges:
            raise ValueError("--samples needs at least one --range")
        drawn = samples(ranges, ns.samples, ns.seed)
        variants = [{**g, **s} for g in variants for s in drawn]
    elif ns.range:
        raise ValueError("--range needs --samples N")
    if ns.variants:
        listed = [json.loads(ln) for ln in Path(ns.variants).read_text().splitlines() if ln.strip()]
        variants = listed if variants == [{}] else variants + listed
    if variants == [{}] and not (ns.grid or ns.samples or ns.variants):
        raise ValueError("nothing to sweep: give --grid, --samples or --variants")
    return variants


def summary_table(df, keys: Sequence[str], max_rows: int = 40) -> str:
    """The printed summary: swept keys, status, steps, times, final energy, first probe,
    metrics; then the count of each status."""
    cols = [c for c in keys if c in df.columns]
    cols += [c for c in ("status", "steps", "failed_steps", "wall_s", "stable_step", "E_total")
             if c in df.columns]
    cols += [c for c in df.columns if c.startswith("probe0_") or c.startswith("metric")]
    import pandas as pd
    with pd.option_context("display.max_rows", max_rows, "display.width", 160,
                           "display.float_format", "{:.6g}".format):
        text = df[cols].to_string(index=False, max_rows=max_rows)
    counts = df["status"].value_counts()
    return text + "\n" + ", ".join(f"{n} {s}" for s, n in counts.items()) + \
        f" ({len(df)} variants)"


def _stress_table(df) -> str:
    """The serial `defsim stress` table: runs per scene and backend by class."""
    lines = [f"{'scene':<10} {'backend':<18} {'stable':>8} {'blowup':>8} {'nonfinite':>8} "
             f"{'error':>8} {'runs':>8}"]
    classes = df["csv_row"].str.split(",").str[6]
    for (scene, backend), idx in df.groupby(["scene", "backend"], sort=False).groups.items():
        c = classes[idx].value_counts()
        lines.append(f"{scene:<10} {backend:<18} {c.get('stable', 0):>8} "
                     f"{c.get('energy_blowup', 0):>8} {c.get('non_finite', 0):>8} "
                     f"{c.get('clean_error', 0):>8} {len(idx):>8}")
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    tool_args: List[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, tool_args = argv[:cut], argv[cut + 1:]
    ns = _parser().parse_args(argv)
    try:
        import distributed  # noqa: F401
        import pandas  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError as exc:
        print(f"defsim-sweep: {exc.name} is missing: pip install './bindings/python[sweep]'",
              file=sys.stderr)
        return 1
    from .._cli import find_defsim
    from ._engine import finish_bench, run_sweep, run_tool_sweep, write_tool_csv
    out = Path(ns.out)
    try:
        # Found here, before a cluster starts, so that a missing one is named by this flag.
        ns.exe = find_defsim(ns.exe, option="--exe PATH")
        if ns.tool:
            if ns.scene or ns.grid or ns.samples or ns.variants:
                print("defsim-sweep: --tool takes the tool's own arguments after --",
                      file=sys.stderr)
                return 2
            df = run_tool_sweep(ns.tool, tool_args, out, scheduler=ns.scheduler,
                                workers=ns.workers, resume=ns.resume, timeout=ns.timeout,
                                exe=ns.exe, progress=not ns.no_progress)
            failed = df[df["csv_row"] == ""]
            for _, r in failed.iterrows():
                print(f"run {r['index']}: {r['status']}: {r['message']}", file=sys.stderr)
            if len(failed):
                return 1
            if ns.tool == "bench":
                # The serial bench assembles the CSV, Pareto table and plot from the rows.
                print(finish_bench(df, tool_args, out / "bench_rows.csv", exe=ns.exe), end="")
                return 0
            csv = out / f"{ns.tool}.csv"
            write_tool_csv(df, csv)
            print(_stress_table(df))
            violations = int((df["status"] == "violation").sum())
            print(f"{len(df)} runs written to {csv}" +
                  (f", {violations} violations" if "--check" in tool_args else ""))
            return 1 if violations else 0
        if not ns.scene:
            print("defsim-sweep: give a scene file (or --tool)", file=sys.stderr)
            return 2
        variants = build_variants(ns)
        df = run_sweep(ns.scene, variants, out, scheduler=ns.scheduler, workers=ns.workers,
                       resume=ns.resume, keep_output=ns.keep_output, threads=ns.threads,
                       timeout=ns.timeout, exe=ns.exe, progress=not ns.no_progress)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"defsim-sweep: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        # The rows that arrived are on disk (the engine flushes them on the way out).
        print(f"\ndefsim-sweep: interrupted; the finished variants are in {out / 'results'}; "
              "--resume runs the others", file=sys.stderr)
        return 130
    keys = list(dict.fromkeys(k for v in variants for k in v))
    print(summary_table(df, keys))
    print(f"ran {len(df.attrs['ran'])} variants now; results: {out / 'results'}")
    if ns.plot:
        from ._plot import heat_map
        try:
            png = heat_map(df, keys, ns.plot_value, out / "sweep.png",
                           title=f"{Path(ns.scene).stem}: {ns.plot_value}")
            print(f"plot: {png}")
        except (ImportError, ValueError) as exc:
            print(f"defsim-sweep: no plot: {exc}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
