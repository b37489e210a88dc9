"""The `mechnet` command: run the example scenes, simulate, export or study the accuracy of one scene file.

    mechnet --version
    mechnet demo [--out DIR] [--only NAME] [--dir DIR] [--debug]
    mechnet simulate FILE [--t-end T] [--rtol R] [--atol A] [--method M] [--n-out N] [--plot PNG] [--csv CSV]
                          [--debug]
    mechnet export FILE --kind fmu|c|casadi [--fmi 2|3] [--all-parameters] [--overwrite] -o OUT [--debug]
    mechnet accuracy FILE [--t-end T] [--at T1] [--methods M ...] [--tolerances R ...] [--target E]
                          [--workers N | --scheduler ADDRESS] [-o DIR] [--debug]

Outputs: a command writes only the files it names and never deletes a folder. A file output
(`simulate --csv/--plot`, `demo --out`'s `<scene>.png`, `accuracy -o`'s `<model>_accuracy.png/.md/.csv`)
replaces a file of that name, as `cp` does; other files in the folder are left alone. `export` writes a
whole folder (or an .fmu archive), so an existing OUT is refused unless `--overwrite`, and even then
only a previous mechnet export is replaced (a folder with only its model.json and the files mechnet
wrote beside it, an empty folder, or a mechnet FMU), never `.`, a parent of the working directory or a
folder holding other files. An export is written beside OUT and renamed into place when complete, so
an interrupted one leaves OUT as it was.

Errors a user can cause (MechnetError) print one `error: ...` line and exit
with status 2, without a traceback: the message already names the culprit
(for a scene file's own code, `<file>:<line>: ...`). `--debug` adds the traceback.
"""
from __future__ import annotations

import argparse
import sys
import time
import traceback
from pathlib import Path
from typing import Optional, Sequence

from mechnet.core.arguments import output_file
from mechnet.core.errors import MechnetError, SceneError
from mechnet.simulate.solvers import METHODS


from .accuracy import METHODS as ACCURACY_METHODS  # noqa: E402


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the console script; returns the process exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.version:
        print(f"mechnet {_version()}")
        return 0
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.run(args)
    except MechnetError as exc:
        print(f"error: {exc}", file=sys.stderr)
        if args.debug:
            traceback.print_exception(exc)
        return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mechnet",
        description="Acausal mechanical modelling on CasADi: build, compile and simulate scenes.",
    )
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", help="print the traceback of an error too")

    demo = sub.add_parser("demo", parents=[common],
                          help="build and simulate every example scene, write PNG plots")
    demo.add_argument("--out", type=Path, default=Path("mechnet-demo"),
                      help="folder for the plots (default: ./mechnet-demo)")
    demo.add_argument("--only", metavar="NAME", help="run only the scene NAME.py")
    demo.add_argument("--dir", "--examples", dest="dir", type=Path, default=None, metavar="DIR",
                      help="run the scene files in DIR (default: mechnet's own examples)")
    demo.set_defaults(run=_demo)

    sim = sub.add_parser("simulate", parents=[common], help="compile and simulate one scene file")
    sim.add_argument("file", type=Path, metavar="FILE", help="scene file defining build()")
    sim.add_argument("--t-end", type=float, default=None, help="end time in s (default: the scene's t_end)")
    sim.add_argument("--rtol", type=float, default=None, help="relative tolerance (default 1e-6)")
    sim.add_argument("--atol", type=float, default=None, help="absolute tolerance (default 1e-8)")
    sim.add_argument("--method", choices=METHODS, default=None, help="integrator (default: auto)")
    sim.add_argument("--n-out", type=int, default=None, help="number of output points")
    sim.add_argument("--plot", type=Path, default=None, metavar="PNG", help="save a plot to this file")
    sim.add_argument("--csv", type=Path, default=None, metavar="CSV", help="write every variable to this CSV file")
    sim.set_defaults(run=_simulate)

    exp = sub.add_parser("export", parents=[common], help="compile one scene file and export it (FMU, C, CasADi)")
    exp.add_argument("file", type=Path, metavar="FILE", help="scene file defining build()")
    exp.add_argument("--kind", choices=("fmu", "c", "casadi"), default="fmu", help="what to write (default: fmu)")
    exp.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version of an FMU (default: 2)")
    exp.add_argument("--all-parameters", action="store_true",
                     help="expose every scalar parameter (not only the scene's tunable ones) as a tunable parameter")
    exp.add_argument("--overwrite", action="store_true",
                     help="replace OUT if it is a previous mechnet export (never a folder holding other files)")
    exp.add_argument("-o", "--out", type=Path, required=True, metavar="OUT",
                     help="the .fmu file (kind fmu) or the folder (kinds c and casadi) to write")
    exp.set_defaults(run=_export)

    acc = sub.add_parser("accuracy", parents=[common],
                         help="work-precision study of one scene file: error against time over methods and tolerances")
    acc.add_argument("file", type=Path, metavar="FILE", help="scene file defining build()")
    acc.add_argument("--t-end", type=float, default=None, help="end time in s (default: the scene's t_end, at most 10 s)")
    acc.add_argument("--at", type=float, default=None, help="time of the error in s (default: the end time)")
    acc.add_argument("--methods", nargs="+", default=None, metavar="METHOD",
                     help="methods to compare (default: all that apply): " + ", ".join(ACCURACY_METHODS))
    acc.add_argument("--tolerances", nargs="+", type=float, default=None, metavar="RTOL",
                     help="relative tolerances (default 1e-3 ... 1e-10)")
    acc.add_argument("--target", type=float, default=1e-6, help="error to recommend settings for (default 1e-6)")
    acc.add_argument("--workers", type=int, default=0, help="worker processes for the runs (default: here)")
    acc.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="run on a Dask cluster (tcp://host:8786) instead of local workers")
    acc.add_argument("-o", "--out", type=Path, default=None, metavar="DIR",
                     help="folder for the plot, table (.md) and CSV (default: ./mechnet-accuracy)")
    acc.set_defaults(run=_accuracy)
    return parser


def _accuracy(args: argparse.Namespace) -> int:
    import math

    from mechnet.accuracy import TOLERANCES, study
    from mechnet.scene import load_scene

    out = args.out or Path("mechnet-accuracy")
    if out.exists() and not out.is_dir():    # said now, not after the study
        raise SceneError(f"-o {out} is a file; give a folder for the plot, table and CSV")
    if not (math.isfinite(args.target) and args.target > 0):
        raise MechnetError(f"--target {args.target:g}: give the error to recommend settings for, a number > 0")
    scene = load_scene(args.file)
    cm = scene.model().compile()
    t_end = args.t_end if args.t_end is not None else min(scene.t_end, 10.0)
    client = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise MechnetError("--scheduler needs dask.distributed: pip install 'mechnet[dask]'") from None
        try:
            client = Client(args.scheduler, timeout=30)
        except (OSError, TimeoutError) as exc:
            raise MechnetError(f"--scheduler {args.scheduler}: cannot reach the Dask scheduler ({exc})") from None
    t0 = time.perf_counter()
    try:
        result = study(cm, t_end, at=args.at, methods=args.methods, tolerances=tuple(args.tolerances or TOLERANCES),
                       reference=scene.reference, workers=args.workers, client=client)
    finally:
        if client is not None:
            client.close()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MechnetError(f"-o {out}: cannot make the folder ({exc.strerror or exc})") from None
    stem = out / f"{cm.name}_accuracy"
    import matplotlib.pyplot as plt
    plt.close(result.plot(stem.with_suffix(".png")))
    stem.with_suffix(".md").write_text(result.to_markdown(args.target) + "\n", encoding="utf-8")
    result.to_csv(stem.with_suffix(".csv"))
    print(result.to_markdown(args.target))
    print(f"\nrecommended for error <= {args.target:g}:\n{result.recommendation(args.target)}")
    print(f"\nwrote {stem}.png, .md and .csv in {time.perf_counter() - t0:.1f} s")
    return 0


def _export(args: argparse.Namespace) -> int:
    from contextlib import nullcontext

    import mechnet as mn
    from mechnet.export.files import CLI_NAMES, export, replaceable
    from mechnet.scene import load_scene

    replaceable(args.out, args.kind, args.overwrite, CLI_NAMES)    # refused before the compile, not after
    scene = load_scene(args.file)
    with mn.every_parameter_tunable() if args.all_parameters else nullcontext():
        model = scene.model()
    t0 = time.perf_counter()
    cm = model.compile()
    # cm.export's own checks, its messages naming -o and --overwrite rather than export(path=...)
    path = export(cm, args.out, args.kind, fmi=args.fmi, overwrite=args.overwrite, _option="cli")
    meta = cm.functions()["metadata"]
    what = f"FMI {args.fmi}.0 Model Exchange FMU" if args.kind == "fmu" else f"kind {args.kind!r} export"
    print(f"wrote {path}: {what} of {cm.name!r} in {time.perf_counter() - t0:.2f} s")
    print(f"  {len(meta['x'])} states, {len(meta['z'])} algebraic (solved inside), {len(meta['u'])} inputs, "
          f"{len(meta['p'])} tunable parameters, {len(meta['d'])} modes, {len(meta['zero'])} event indicators, "
          f"{len(meta['time_events'])} time events")
    print(f"  states: {meta['selection']['reason']}")
    if meta["folded_parameters"]:
        print(f"  {len(meta['folded_parameters'])} parameters folded into the equations as numbers "
              f"(--all-parameters exposes them)")
    return 0


def _version() -> str:
    try:
        from importlib.metadata import PackageNotFoundError, version
        return version("mechnet")
    except PackageNotFoundError:
        import mechnet
        return getattr(mechnet, "__version__", "unknown")


def _use_agg() -> None:
    """Plots are only written to files, so never open a window (CI has no display)."""
    import matplotlib
    matplotlib.use("Agg")


def _examples_dir(override: Optional[Path]) -> Path:
    """DIR when given, else mechnet's own examples/: those of the checkout this package is installed from.

    Only a src/ layout checkout (src/mechnet next to pyproject.toml) counts, so a folder that merely
    happens to sit near an installed package is never run.
    """
    if override is not None:
        if not override.is_dir():
            raise SceneError(f"--dir {override}: no such folder of scene files")
        return override
    package = Path(__file__).resolve().parent
    root = package.parents[1]
    folder = root / "examples"
    if package.parent.name != "src" or not (root / "pyproject.toml").is_file() or not folder.is_dir():
        raise SceneError(
            "this mechnet install has no example scenes (they come with the source checkout: "
            "pip install -e .); pass --dir DIR to run the scene files in DIR"
        )
    return folder


def _report(scene, res, png: Optional[Path]) -> None:
    """Print max |name - reference| per name of the scene's reference(t); plot its `plot` names
    (default: the first states) to `png` with `res.plot`, titled with the scene, the reference overlaid."""
    reference = scene.reference_errors(res)
    for name, (_, error) in reference.items():
        print(f"  max |{name} - reference| = {error:.3e}")
    if png is None:
        return
    names = list(scene.plot) or list(res.state_names[:6])
    fig = res.plot(names, title=scene.title,
                   reference={name: values for name, (values, _) in reference.items() if name in names})
    _save(fig, png)


def _save(fig, png: Path) -> None:
    """Write a figure and close it; a path that cannot be written is a MechnetError naming it."""
    import matplotlib.pyplot as plt

    try:
        fig.savefig(png)
    except OSError as exc:
        raise MechnetError(f"cannot write the plot {png}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)
    print(f"wrote {png}")


def _optimal_control(scene, cm, png: Path) -> None:
    """Solve the scene's optimal control problem, replay its controls, plot the solution."""
    t0 = time.perf_counter()
    sol = scene.solve(cm)
    stats = sol.stats
    print(f"optimal control ({stats['method']}, N = {stats['N']}): {stats['status']} after {stats['iterations']} "
          f"iterations in {time.perf_counter() - t0:.3f} s; objective {stats['objective']:.6g}, "
          f"t_final = {sol.t_final:.6g} s")
    print(f"  state selection: {stats['selection']}")
    check = sol.verify()
    print(f"  replayed by cm.simulate: max state deviation {check['max_deviation']:.3e} ({check['worst']})")
    fig = sol.plot(title=f"{scene.title} — optimal control")
    _save(fig, png)
    if not sol.success:
        worst = stats["worst_constraint"]
        raise MechnetError(f"the optimal control problem failed: {sol!r}" +
                           (f"; largest violation {stats['max_violation']:.3g} in {worst[0]} at t = {worst[1]:.6g} s"
                            if worst else ""))


def _demo(args: argparse.Namespace) -> int:
    """Run every scene; one failing scene is reported and does not stop the others."""
    _use_agg()
    from mechnet.scene import load_scene

    folder = _examples_dir(args.dir)
    files = sorted(p for p in folder.glob("*.py") if not p.name.startswith("_"))
    if args.only is not None:
        files = [p for p in files if p.stem == args.only]
        if not files:
            names = ", ".join(sorted(p.stem for p in folder.glob("*.py"))) or "none"
            raise SceneError(f"no scene named {args.only!r} in {folder} (available: {names})")
    if not files:
        raise SceneError(f"no scene files (*.py) in {folder}")

    out: Path = args.out
    if out.exists() and not out.is_dir():
        raise SceneError(f"--out {out} is a file; give a folder for the plots")
    out.mkdir(parents=True, exist_ok=True)
    failed: list[str] = []
    t_total = time.perf_counter()
    for path in files:
        print(f"\n=== {path.stem} " + "=" * max(3, 60 - len(path.stem)))
        try:
            scene = load_scene(path)
            if scene.description:
                print(scene.description)
            t0 = time.perf_counter()
            model = scene.model()
            cm = model.compile()
            t_compile = time.perf_counter() - t0
            print(cm.summary())
            scene.check_plot(cm.names)
            t0 = time.perf_counter()
            res = cm.simulate(scene.t_end)
            t_sim = time.perf_counter() - t0
            print(f"build + compile {t_compile:.3f} s, simulate to t = {scene.t_end:g} s {t_sim:.3f} s")
            _report(scene, res, out / f"{scene.name}.png")
            if scene.optimize is not None:
                _optimal_control(scene, cm, out / f"{scene.name}_ocp.png")
        except Exception as exc:  # noqa: BLE001 - report and go on with the next scene
            failed.append(path.stem)
            kind = "" if isinstance(exc, MechnetError) else f"{type(exc).__name__}: "
            print(f"error: {path.stem}: {kind}{exc}", file=sys.stderr)
            if args.debug:
                traceback.print_exception(exc)
    print(f"\n{len(files) - len(failed)} of {len(files)} scenes ran in "
          f"{time.perf_counter() - t_total:.2f} s; plots in {out}")
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


def _simulate(args: argparse.Namespace) -> int:
    from mechnet.scene import load_scene

    # Output paths are checked before the (possibly long) run, not when it is over; a missing folder is
    # made, as `demo --out` makes its own
    for option, path in (("--csv", args.csv), ("--plot", args.plot)):
        if path is not None:
            folder = Path(path).expanduser().absolute().parent
            if not folder.exists():
                try:
                    folder.mkdir(parents=True)
                except OSError as exc:
                    raise SceneError(f"{option} = {str(path)!r}: cannot make the folder {str(folder)!r} "
                                     f"({exc})") from None
            output_file(path, option, SceneError)
    if args.plot is not None:
        _use_agg()
        _check_plot_format(args.plot)
    scene = load_scene(args.file)
    t0 = time.perf_counter()
    cm = scene.model().compile()
    t_compile = time.perf_counter() - t0
    scene.check_plot(cm.names)        # a typo in `plot` is found now, --plot or not, before any output
    print(cm.summary())

    # Only options the user gave are passed on, so the simulator's own defaults apply.
    options = {key: value for key, value in
               (("rtol", args.rtol), ("atol", args.atol), ("method", args.method), ("n_out", args.n_out))
               if value is not None}
    t_end = scene.t_end if args.t_end is None else args.t_end
    t0 = time.perf_counter()
    res = cm.simulate(t_end, **options)
    t_sim = time.perf_counter() - t0
    print(f"build + compile {t_compile:.3f} s, simulate to t = {t_end:g} s {t_sim:.3f} s")

    names = list(cm.state_names)
    width = max((len(n) for n in names), default=0)
    if not res.success:
        print(f"warning: {res.failure}", file=sys.stderr)
    print(f"final state at t = {res.final_time:g} s:")
    for name in names:
        print(f"  {name:<{width}}  {float(res[name][-1]): .9g}")
    for event in res.events:
        print(f"  event at t = {event.t:g} s ({event.kind}): {event.cause}")
    if args.csv is not None:
        try:
            res.to_csv(args.csv)
        except OSError as exc:
            raise MechnetError(f"cannot write --csv {args.csv}: {exc.strerror or exc}") from exc
        print(f"wrote {args.csv}")
    _report(scene, res, args.plot)
    return 0


def _check_plot_format(png: Path) -> None:
    """matplotlib picks the format from the suffix: refuse one it cannot write before the run."""
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = png.suffix.lstrip(".").lower()
    if suffix not in formats:
        raise SceneError(f"--plot {png}: matplotlib cannot write {'.' + suffix if suffix else 'a file without a suffix'}"
                         f"; use one of {', '.join('.' + f for f in sorted(formats))}")


if __name__ == "__main__":
    sys.exit(main())
