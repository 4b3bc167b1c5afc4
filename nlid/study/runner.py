"""Running a study end to end: plan, skip what is done, execute, persist, report."""

from __future__ import annotations

import dataclasses
import importlib
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from ..runtime.outputs import STUDY_OUTPUTS, output_folder
from . import columns as col
from .config import StudyConfig
from .execute import LocalExecutor
from .plan import Run, plan_study
from .store import ResultStore
from .worker import failure_payload

__all__ = ["Progress", "StudyOutcome", "run_study"]


class Progress:
    """A one-line progress display (runs done / total, elapsed, ETA) on a terminal.

    Parameters
    ----------
    total
        Runs to execute in this session.
    label
        Shown before the counts.
    stream
        Default ``sys.stderr``.
    enabled
        Default: only when ``stream`` is a terminal (quiet in CI and pipes).
    """

    def __init__(self, total: int, label: str = "", stream: TextIO | None = None, enabled: bool | None = None):
        self.total, self.label = total, label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = bool(self.stream.isatty()) if enabled is None else enabled
        self.done = 0
        self.failed = 0
        self.start = time.monotonic()

    def line(self) -> str:
        """The current progress text."""
        elapsed = time.monotonic() - self.start
        pct = 100.0 * self.done / self.total if self.total else 100.0
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        text = f"{self.label}{self.done}/{self.total} runs ({pct:.0f} %), {_clock(elapsed)} elapsed"
        text += f", ETA {_clock(eta)}" if self.done < self.total else ""
        return text + (f", {self.failed} failed" if self.failed else "")

    def update(self, failed: bool = False) -> None:
        """Count one finished run and redraw."""
        self.done += 1
        self.failed += int(failed)
        if self.enabled:
            self.stream.write("\r\x1b[2K" + self.line())
            self.stream.flush()

    def close(self) -> None:
        """End the progress line."""
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def _clock(seconds: float) -> str:
    if seconds != seconds:  # NaN
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


@dataclass
class StudyOutcome:
    """What :func:`run_study` did and where the outputs are."""

    folder: Path
    runs: list[Run]
    executed: int
    skipped: int
    summary: str
    report: Path | None
    name: str = ""

    def to_dict(self) -> dict[str, Any]:
        """What ``nlid study run --json`` prints: the study, where its outputs are, and one row per run.

        ``results`` holds the stored row of every run of the study (the rows of ``results.csv``, in plan
        order; a run without a stored result is left out).
        """
        from ..base.jsonable import to_jsonable

        rows = [record["row"] for record in ResultStore(self.folder).records(self.runs)]
        return to_jsonable(
            {
                "study": self.name,
                "folder": str(self.folder),
                "report": None if self.report is None else str(self.report),
                "runs": len(self.runs),
                "executed": self.executed,
                "skipped": self.skipped,
                "results": rows,
            }
        )


def run_study(
    config: StudyConfig,
    folder: str | Path,
    *,
    executor: Any = None,
    rerun: bool = False,
    report: bool = True,
    progress: bool | None = None,
    log: TextIO | None = None,
    force: bool = False,
    timeout: float | None = None,
) -> StudyOutcome:
    """Run every run of a study not yet done, persisting each as it finishes, then report.

    Parameters
    ----------
    config
        From :func:`nlid.study.load_study`.
    folder
        Output folder (created; results of earlier sessions are kept and
        reused). nlid writes only into folders it created or that were empty,
        and locks the folder while the study runs (:mod:`nlid.runtime.outputs`).
    executor
        :class:`~nlid.study.execute.LocalExecutor` (default) or
        :class:`~nlid.study.execute.DaskExecutor`.
    rerun
        Run everything again, even runs already stored.
    report
        Write ``results.csv``, ``summary.md``, figures and ``report.html``.
    progress
        Show the progress line (default: when stderr is a terminal).
    log
        Where one-line status messages go (default ``sys.stderr``; ``None`` is the default).
    force
        Write into a folder that holds files nlid did not write. They are never
        replaced: a file with the name of an output stops the study before
        anything is written (:data:`nlid.runtime.outputs.STUDY_OUTPUTS`).
    timeout
        Time limit of each run in seconds, instead of the study's
        ``timeout`` (600 s unless the study sets one); ``math.inf``: none.
        Not part of a run's digest: stored runs are reused whatever it is.

    Raises
    ------
    InputError
        The folder holds files nlid did not write, or cannot be written.
    FolderBusyError
        Another process is running a study in the folder.
    """
    with output_folder(folder, STUDY_OUTPUTS, force=force) as path:
        return _run_study(config, path, executor, rerun, report, progress, log, timeout)


#: What the report is written with (pandas, matplotlib's figure and both backends: ~1.2 s of imports).
_REPORT_MODULES = (
    "nlid.study.report",
    "matplotlib.figure",
    "matplotlib.backends.backend_agg",
    "matplotlib.backends.backend_svg",
)


def _warm_report() -> threading.Thread:
    """Import what the report needs on a thread of its own while the runs execute (this process only waits on them).

    Then draw a figure into memory and drop it (:func:`_draw_nothing`), so that the report is written without
    the imports and what matplotlib builds for its first figure. Nothing is written; an import that fails here
    fails again, with its message, where the report needs it.
    """

    def imports() -> None:
        for name in _REPORT_MODULES:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001 - raised again where the report imports it
                return
        try:
            _draw_nothing()
        except Exception:  # noqa: BLE001 - a warm-up only: the report draws (and fails) on its own
            return

    thread = threading.Thread(target=imports, name="nlid-report-imports", daemon=True)
    thread.start()
    return thread


def _draw_nothing() -> None:
    """Draw a small figure with a log axis, a title and a legend into memory, as PNG and SVG, and drop it.

    What matplotlib builds on the first figure it draws, once per process, is then built: the fonts, the
    mathtext parser (the log axes' tick labels are mathtext, ``$10^{-1}$``; its grammar takes ~0.3 s to
    build) and each backend's glyph caches. The report's figures are drawn as before, with the same
    numbers.
    """
    import io

    from ..report.plotting import new_figure

    fig, axes = new_figure(1, 2, width=3.0, height=2.0)
    for ax in axes:
        ax.bar([0.0, 1.0], [0.05, 20.0], yerr=[[0.01, 1.0], [0.01, 1.0]], label="x")
        ax.set_yscale("log")
        ax.set_xticks([0.0, 1.0], ["a", "b"], rotation=30, ha="right", fontsize=8)
        ax.set_title("a title", fontsize=9)
    axes[0].set_ylabel("median")
    fig.legend(loc="outside upper center", ncols=2, fontsize=9)
    for fmt in ("png", "svg"):
        fig.savefig(io.BytesIO(), format=fmt, dpi=120)


def _run_study(
    config: StudyConfig,
    folder: Path,
    executor: Any,
    rerun: bool,
    report: bool,
    progress: bool | None,
    log: TextIO | None,
    timeout: float | None = None,
) -> StudyOutcome:
    log = log if log is not None else sys.stderr
    store = ResultStore(folder)
    (store.folder / "study.toml").write_text(config.text)
    runs = plan_study(config)
    todo = runs if rerun else [r for r in runs if not store.is_done(r)]
    if timeout is not None:
        from ..identification.pipeline import check_timeout

        limit = check_timeout(timeout)
        todo = [dataclasses.replace(r, spec=dataclasses.replace(r.spec, timeout=limit)) for r in todo]
    skipped = len(runs) - len(todo)
    executor = executor or LocalExecutor()
    for name, why in config.skipped_identifiers.items():
        log.write(f"nlid study: plugin {name!r} is not used: {why}\n")
    log.write(
        f"nlid study {config.name}: {len(runs)} runs ({len(config.datasets)} dataset(s), "
        f"{sum(len(d.models) for d in config.datasets)} term set(s), {len(config.identifiers)} identifier(s): "
        f"{', '.join(config.identifiers)}), {skipped} already done, {len(todo)} to run "
        f"with the {executor.name} executor; results in {store.folder}\n"
    )
    bar = Progress(len(todo), label=f"{config.name}: ", stream=log, enabled=progress)

    def on_done(run: Run, payload: dict[str, Any]) -> None:
        try:
            if not store.save(run, payload):  # nlid's fork server died under it: not the run's result
                why = payload["row"].get(col.ERROR.key(), "")
                clear = "\r\x1b[2K" if bar.enabled else ""
                log.write(f"{clear}nlid study: {run.run_id}: {why}; not saved: it runs again on resume\n")
        except (TypeError, ValueError, OverflowError, RecursionError, KeyError) as exc:
            # a result that cannot be stored (e.g. an object among a plugin's diagnostics) is that run's failure
            why = f"identifier {run.spec.method!r} returned a result that cannot be stored: {type(exc).__name__}: {exc}"
            payload = failure_payload(run.spec, "failed", why)
            store.save(run, payload)
        bar.update(failed=payload["row"]["status"] != "ok")

    warm = _warm_report() if report and todo else None
    try:
        executor.run(todo, on_done)
    finally:
        bar.close()
        if warm is not None:
            warm.join()
    summary_text = ""
    report_path = None
    if report:
        from .report import write_report

        summary_text, report_path = write_report(config, runs, store)
    return StudyOutcome(store.folder, runs, len(todo), skipped, summary_text, report_path, config.name)
