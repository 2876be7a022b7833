"""Runs one scenario many times over axes of variation and gathers one results table.

Each variant is a headless world run (``python -m armando_drake.world ...
--set OVERRIDE --output OUT/variants/NNNN``), in a process of its own, on a
local process pool (``--workers N``, default one per CPU) or on a Ray cluster
(``--ray auto|local|ADDRESS``). The results go to OUT/results.csv and
OUT/results.parquet: the variant's values, status, exit code, error line, wall
time, metrics and every number of its summary.json (see
armando_drake/sweeps/table.py for the columns). A failing variant is recorded
with its error, and the others go on. --resume skips the variants OUT already
holds a result for (OUT/variants/NNNN/result.json) except the interrupted
ones; --retry-failed runs the failed and timed-out ones again too. --plot
draws the sweep's figure of --metric into OUT/<metric>.png: a heat map over
two axes, a line over one.

Axes: --grid KEY=[v1, v2, ...] (or linspace(a, b, n), geomspace(a, b, n)),
--random KEY=uniform(a, b) | loguniform(a, b) | normal(mean, std) |
integers(a, b) | choice([x, y, ...]) with --samples N and --seed S. KEY is any
scenario key path (actuators.kp, sequencer.period, robot.collision); a segment
may carry a YAML type tag for a tagged union, name!Tag. The variants are the
grid's combinations (first axis slowest) times the random samples.

Examples:
  python -m armando_drake.sweep --grid 'actuators.kp=[2,4,8,16]' --grid 'actuators.kd=[0.1,0.4]' \\
      --output out/gains --plot --metric settle_time
  python -m armando_drake.sweep --random 'actuators.kp=uniform(1,20)' --samples 200 --seed 1 \\
      --output out/kp --workers 2
  python -m armando_drake.sweep --grid 'actuators.kp=[2,4,8,16]' --output out/gains --resume
  python -m armando_drake.sweep --grid 'actuators.kp=geomspace(1,64,7)' --ray auto --output out/k
  python -m armando_drake.sweep --grid 'actuators.kp=[4,8]' --dry-run
  python -m armando_drake.sweep --scenario fra2mo_goals \\
      --grid 'nav.controller_server.FollowPath.desired_linear_vel=[0.3,0.5]' --metric nav_time
  python -m armando_drake.sweep @diagrams/sweeps/nav2_configurations.args

A key nav.NODE.PLUGIN.PARAMETER is a parameter of the navigation's Nav2 YAML
(navigation.params_overrides). @FILE reads arguments from FILE, one a line.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import json
import signal
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from armando_drake.sweeps.axes import Variant, make_variants, parse_grid, parse_random
from armando_drake.sweeps.engines import make_engine
from armando_drake.sweeps.errors import SweepError, reported
from armando_drake.sweeps.plot import plot_sweep
from armando_drake.sweeps.table import METRICS, NAVIGATION_METRICS, ResultsTable, row
from armando_drake.sweeps.variant import INTERRUPTED, OK, VariantResult, VariantTask, run_variant
from armando_drake.tools.cli import command_parser

SWEEP_FILE = "sweep.json"  # what the sweep is: scenario, axes, variants
RESULT_FILE = "result.json"  # in each variant's folder: its values and result


@dataclass
class Sweep:
    """What to run: one scenario, its variants, and what every variant shares."""

    scenario: str  # a name in diagrams/ or a path to a scenario YAML
    variants: list[Variant]
    common_overrides: list[str] = field(default_factory=list)  # --set for every variant
    world_args: list[str] = field(default_factory=list)  # more world arguments for every run
    timeout: float | None = None  # [s] per run; None: no limit
    axes: list[str] = field(default_factory=list)  # the axes as given, for sweep.json

    def task(self, variant: Variant, output: Path) -> VariantTask:
        return VariantTask(
            index=variant.index,
            scenario=self.scenario,
            overrides=variant.overrides(),
            output=str(output / "variants" / f"{variant.index:04d}"),
            common_overrides=list(self.common_overrides),
            world_args=list(self.world_args),
            timeout=self.timeout,
        )

    def identity(self) -> dict:
        """What a stored result must share with this sweep to count as done."""
        return {
            "scenario": self.scenario,
            "common_overrides": self.common_overrides,
            "world_args": self.world_args,
        }


@dataclass
class SweepOutcome:
    """What :func:`run_sweep` did."""

    table: ResultsTable  # every variant with a result, this run's and earlier ones
    ran: int  # variants run now
    skipped: int  # variants taken from an earlier run (--resume)
    failed: int  # variants of the table whose status is not ok
    seconds: float  # [s] wall time of this run of the sweep
    files: tuple[Path, Path]  # results.csv, results.parquet
    interrupted: bool = False  # stopped by Ctrl-C before every variant ran


def _scenario_argument(scenario: str) -> str:
    """A scenario path that exists here becomes absolute (the runs start elsewhere)."""
    path = Path(scenario).expanduser()
    return str(path.resolve()) if path.is_file() else scenario


def _load_result(folder: Path) -> dict | None:
    path = folder / RESULT_FILE
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _write_json(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_text(json.dumps(data, indent=2) + "\n")
    temporary.replace(path)


def _progress(total: int, done: int, failed: int, enabled: bool, engine):
    from tqdm import tqdm

    if enabled:
        print(f"sweep: {total} variants, {done} done before; {engine.describe()}", file=sys.stderr)
    bar = tqdm(
        total=total,
        initial=done,
        desc="sweep",
        unit="run",
        file=sys.stderr,
        disable=not enabled,
        dynamic_ncols=True,
        bar_format="{desc}: {n}/{total} runs{postfix} |{bar}| {elapsed} elapsed, {remaining} left",
        postfix=f"{failed} failed",
    )
    return bar


def _stored_rows(
    sweep: Sweep, output: Path, *, resume: bool, retry_failed: bool
) -> tuple[dict[int, dict], list[Variant]]:
    """(table rows of the variants ``output`` holds a result for, the variants to run);
    without ``resume`` every variant is to run."""
    identity = sweep.identity()
    rows, todo = {}, []
    for variant in sweep.variants:
        folder = output / "variants" / f"{variant.index:04d}"
        stored = _load_result(folder) if resume else None
        if stored is not None:
            same = stored.get("identity") == identity and stored.get("values") == variant.values
            if not same:
                raise SweepError(
                    f"--resume: {folder / RESULT_FILE} is of another sweep (variant "
                    f"{variant.index}: {stored.get('values')} with {stored.get('identity')}, "
                    f"now {variant.values} with {identity}); choose another --output"
                )
            result = VariantResult(**stored["result"])
            if result.status != INTERRUPTED and not (retry_failed and result.status != OK):
                rows[variant.index] = row(variant.values, result)
                continue
        todo.append(variant)
    return rows, todo


def _write_sweep_file(sweep_file: Path, sweep: Sweep) -> None:
    """Writes what the sweep is: its identity, axes, timeout and every variant."""
    _write_json(
        sweep_file,
        {
            **sweep.identity(),
            "axes": sweep.axes,
            "timeout": sweep.timeout,
            "written": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            "variants": [
                {"variant": v.index, "values": v.values, "overrides": v.overrides()}
                for v in sweep.variants
            ],
        },
    )


def _run_variants(
    sweep: Sweep,
    tasks: list[VariantTask],
    output: Path,
    engine,
    rows: dict[int, dict],
    failed: int,
    bar,
) -> tuple[int, bool]:
    """Runs ``tasks`` on ``engine``, each result into its folder and ``rows`` as it comes;
    (variants failed, whether Ctrl-C stopped it). Closes ``bar``."""
    identity = sweep.identity()
    by_index = {v.index: v for v in sweep.variants}
    interrupted = False
    try:
        for result in engine.map_unordered(run_variant, tasks):
            variant = by_index[result.index]
            _write_json(
                output / "variants" / f"{variant.index:04d}" / RESULT_FILE,
                {
                    "variant": variant.index,
                    "values": variant.values,
                    "overrides": variant.overrides(),
                    "identity": identity,
                    "result": result.as_dict(),
                },
            )
            rows[variant.index] = row(variant.values, result)
            failed += result.status != OK
            bar.set_postfix_str(f"{failed} failed", refresh=False)
            bar.update(1)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    return failed, interrupted


def run_sweep(
    sweep: Sweep,
    output: str | Path,
    engine,
    *,
    resume: bool = False,
    retry_failed: bool = False,
    progress: bool = True,
) -> SweepOutcome:
    """Runs the variants of ``sweep`` that ``output`` has no result for; writes the table."""
    output = Path(output).resolve()
    sweep_file = output / SWEEP_FILE
    if sweep_file.exists() and not resume:
        raise SweepError(
            f"--output {output} already holds a sweep ({SWEEP_FILE}); add --resume to continue "
            "it, or choose another folder"
        )
    rows, todo = _stored_rows(sweep, output, resume=resume, retry_failed=retry_failed)
    output.mkdir(parents=True, exist_ok=True)
    _write_sweep_file(sweep_file, sweep)
    skipped = len(rows)
    failed = sum(r["status"] != OK for r in rows.values())
    tasks = [sweep.task(variant, output) for variant in todo]
    start = time.perf_counter()
    bar = _progress(len(sweep.variants), skipped, failed, progress, engine)
    failed, interrupted = _run_variants(sweep, tasks, output, engine, rows, failed, bar)
    table = ResultsTable(rows.values())
    files = table.write(output)
    return SweepOutcome(
        table=table,
        ran=len(rows) - skipped,
        skipped=skipped,
        failed=failed,
        seconds=time.perf_counter() - start,
        files=files,
        interrupted=interrupted,
    )


def _add_scenario_options(parser: argparse.ArgumentParser) -> None:
    """--scenario and --set: the scenario every variant starts from."""
    parser.add_argument(
        "--scenario",
        default="position",
        metavar="FILE",
        help="scenario YAML: a path, or a name in diagrams/ (default: position)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="YAML",
        help="YAML merged over the scenario for every variant, before the variant's own "
        "(repeatable)",
    )


def _add_axis_options(parser: argparse.ArgumentParser) -> None:
    """The "axes" group: --grid, --random, --samples, --seed."""
    axes = parser.add_argument_group("axes")
    axes.add_argument(
        "--grid", action="append", default=[], metavar="KEY=VALUES", help="a grid axis"
    )
    axes.add_argument(
        "--random",
        action="append",
        default=[],
        metavar="KEY=DISTRIBUTION",
        help="a random axis, drawn --samples times",
    )
    axes.add_argument("--samples", type=int, default=0, metavar="N", help="random samples")
    axes.add_argument(
        "--seed", type=int, default=0, metavar="S", help="seed of the random axes (default: 0)"
    )


def _add_run_options(parser: argparse.ArgumentParser) -> None:
    """The "runs" group: where results go, what every run gets, resuming, dry runs."""
    runs = parser.add_argument_group("runs")
    runs.add_argument(
        "--output",
        default="out/sweep",
        metavar="DIR",
        help="the sweep's folder: results.csv, results.parquet, variants/NNNN/ (default: "
        "out/sweep)",
    )
    runs.add_argument(
        "--duration", type=float, metavar="SECONDS", help="simulated time of every run [s]"
    )
    runs.add_argument(
        "--world-arg",
        action="append",
        default=[],
        metavar="ARG",
        help="one more argument for every world run, e.g. --world-arg=--controller=trajectory "
        "(repeatable)",
    )
    runs.add_argument(
        "--timeout", type=float, metavar="SECONDS", help="kill a run after this wall time [s]"
    )
    runs.add_argument("--resume", action="store_true", help="skip variants already done")
    runs.add_argument(
        "--retry-failed", action="store_true", help="with --resume, run failed variants again"
    )
    runs.add_argument(
        "--dry-run", action="store_true", help="print the variants' overrides; run nothing"
    )


def _add_engine_options(parser: argparse.ArgumentParser) -> None:
    """The "engine" group: --workers, --ray, --cpus-per-task."""
    engine = parser.add_argument_group("engine")
    engine.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="runs at once (default: the number of CPUs; with --ray: the cluster's CPUs)",
    )
    engine.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="run on Ray: auto (the running cluster, else a local one), local, or an address "
        "like ray://head:10001 (needs pip install 'armando-drake[cluster]')",
    )
    engine.add_argument(
        "--cpus-per-task",
        type=float,
        default=1.0,
        metavar="N",
        help="with --ray, the CPUs each run reserves (default: 1)",
    )


def _add_figure_options(parser: argparse.ArgumentParser) -> None:
    """The "figure" group: --plot, --metric, --plot-axes."""
    plot = parser.add_argument_group("figure")
    plot.add_argument("--plot", action="store_true", help="draw OUT/<metric>.png")
    plot.add_argument(
        "--metric",
        default="settle_time",
        help="the column to draw: "
        + ", ".join(f"{name} ({what})" for name, what in METRICS.items())
        + "; with a navigation: "
        + ", ".join(NAVIGATION_METRICS)
        + ", or any column of the table such as summary.tracking_error (default: settle_time)",
    )
    plot.add_argument(
        "--plot-axes",
        metavar="KEY[,KEY]",
        help="the axes to draw over (default: the first two); others are reduced to their median",
    )


def _parser() -> argparse.ArgumentParser:
    """The sweep's command line."""
    parser = command_parser("armando_drake.sweep", __doc__)
    parser.fromfile_prefix_chars = "@"  # @FILE: the arguments of a sweep file, one a line
    _add_scenario_options(parser)
    _add_axis_options(parser)
    _add_run_options(parser)
    _add_engine_options(parser)
    _add_figure_options(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def sweep_from_arguments(args: argparse.Namespace) -> Sweep:
    grid = [parse_grid(text) for text in args.grid]
    random = [parse_random(text) for text in args.random]
    variants = make_variants(grid, random, samples=args.samples, seed=args.seed)
    world_args = list(args.world_arg)
    if args.duration is not None:
        if args.duration < 0:
            raise SweepError(f"--duration {args.duration} must not be negative")
        world_args += ["--duration", repr(args.duration)]
    if args.timeout is not None and args.timeout <= 0:
        raise SweepError(f"--timeout {args.timeout} must be positive [s]")
    return Sweep(
        scenario=_scenario_argument(args.scenario),
        variants=variants,
        common_overrides=list(args.set),
        world_args=world_args,
        timeout=args.timeout,
        axes=[*(f"--grid {g}" for g in args.grid), *(f"--random {r}" for r in args.random)]
        + ([f"--samples {args.samples}", f"--seed {args.seed}"] if args.random else []),
    )


def _stop_on_sigterm() -> None:
    """SIGTERM stops the sweep as Ctrl-C does: the runs stop, the table is written."""

    def handler(signum, frame):
        raise KeyboardInterrupt

    with contextlib.suppress(ValueError):  # not the main thread: leave the handler alone
        signal.signal(signal.SIGTERM, handler)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    _stop_on_sigterm()
    with reported():
        sweep = sweep_from_arguments(args)
        if args.dry_run:
            for variant in sweep.variants:
                print(" ".join(sweep.task(variant, Path(args.output)).command()[1:]))
            return 0

        axis_names = list(sweep.variants[0].values)
        plot_axes = _plot_axes(args.plot_axes, axis_names)
        with make_engine(args.ray, args.workers, args.cpus_per_task) as engine:
            outcome = run_sweep(
                sweep,
                args.output,
                engine,
                resume=args.resume,
                retry_failed=args.retry_failed,
                progress=not args.quiet,
            )
        table = outcome.table
        print(
            f"{len(table.rows)} of {len(sweep.variants)} variants: "
            f"{len(table.rows) - outcome.failed} ok, {outcome.failed} failed "
            f"({outcome.ran} run now in {outcome.seconds:.1f} s, {outcome.skipped} done before)"
            + (" [interrupted]" if outcome.interrupted else "")
        )
        for record in table.rows:
            if record["status"] != OK:
                print(f"  variant {record['variant']} ({record['status']}): {record['error']}")
        print(f"table: {outcome.files[0]}, {outcome.files[1]}")
        if args.plot:
            path = Path(args.output) / f"{args.metric}.png"
            plot_sweep(table, plot_axes, args.metric, path)
            print(f"figure: {path}")
    return 130 if outcome.interrupted else 0


def _plot_axes(text: str | None, axis_names: list[str]) -> list[str]:
    if text is None:
        return axis_names[:2]
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in axis_names]
    if unknown or not 1 <= len(names) <= 2:
        raise SweepError(
            f"--plot-axes {text!r}: name one or two of the axes {', '.join(axis_names)}"
        )
    return names
