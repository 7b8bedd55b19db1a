"""The Python API for scripts: one call per run, the same numbers the command line gives.

::

    import piezotip

    result = piezotip.run("grasp", overrides={"object.mass_kg": 0.4}, preset="fast")
    print(result.outcome, result.reason)                  # "success", why
    t_s, p_pa = result.data["time_s"], result.data["left_true_pressure_pa"]
    result.units["left_true_pressure_pa"]                      # "Pa"

    tip = piezotip.fingertip("grasp")                     # the scenario's sensor, as the loop builds it
    tip.dynamic_range()["dynamic_range"]                  # the range within the model (top capped where it ends)

A run needs no output folder: without ``out`` the recording is kept in memory only.  With
``out`` the run writes what ``run_sim.py run`` writes there (``run.npz``, ``summary.json``, and
``run.png`` with ``plot=True``).  Bad input raises ``ValueError`` naming the bad value, as the
command line prints it.  Ctrl-C raises ``KeyboardInterrupt`` out of a run, SIGTERM
:class:`piezotip.interrupts.Terminated` (a KeyboardInterrupt, and a SystemExit with status 143),
each after the partial run is written: a script's loop over runs stops there.
"""

from __future__ import annotations

import signal
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

#: Unit of a recorded column, by the suffix of its name (the record's naming convention).
_UNIT_SUFFIXES = (
    ("_m_s", "m/s"),
    ("_rad_s", "rad/s"),
    ("_pa", "Pa"),
    ("_n", "N"),
    ("_m", "m"),
    ("_s", "s"),
    ("_hz", "Hz"),
    ("_v", "V"),
)

Overrides = Sequence[str] | Mapping[str, object] | None


def column_unit(name: str) -> str:
    """The unit of recorded column ``name`` from its suffix (``"1"`` for dimensionless ones)."""
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    return "1"


@dataclass(frozen=True)
class Result:
    """One finished run.

    Attributes
    ----------
    scenario : the scenario's name.
    overrides : the overrides applied, as ``key=value`` strings (a mapping is converted).
    preset : the fidelity preset, or None.
    summary : what ``run_sim.py run --json`` prints (``summary.json``): outcome, reason, the
        referee's numbers, pressures, modes, timings; units in the key names.
    data : the recording, one array per column, a row per control step; units in the column
        names (see :attr:`units`).
    events : the controller's events (time_s, pad, kind, message), in order.
    out_dir : where the files were written, or None for an in-memory run.
    """

    scenario: str
    overrides: tuple[str, ...]
    preset: str | None
    summary: Mapping[str, object]
    data: Mapping[str, np.ndarray]
    events: tuple[Mapping[str, object], ...]
    out_dir: Path | None = None
    units: Mapping[str, str] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "units", MappingProxyType({name: column_unit(name) for name in self.data}))

    @property
    def outcome(self) -> str:
        """The referee's outcome: ``success``, ``crushed``, ``dropped``, ``slipped``, ... (see OUTCOMES)."""
        return str(self.summary["outcome"])

    @property
    def reason(self) -> str:
        """Why the referee judged the outcome it did, in words."""
        return str(self.summary["reason"])

    @property
    def success(self) -> bool:
        """Whether the grasp was a success as someone watching would judge it."""
        return bool(self.summary["success"])

    @property
    def grip_margin(self) -> float:
        """The grip held over the least grip that holds the object (``hold_grip_n / needed_grip_n``,
        from the simulator's truth; NaN if the object was never carried clear of the table)."""
        value = self.summary.get("grip_margin")
        return float("nan") if value is None else float(value)


def run(
    scenario: str = "grasp",
    overrides: Overrides = None,
    preset: str | None = None,
    *,
    out: str | Path | None = None,
    plot: bool = False,
    csv: bool = False,
    video: bool = False,
    video_fps: float | None = None,
    video_size: tuple[int, int] | None = None,
    progress: bool = False,
) -> Result:
    """Run ``scenario`` headless and return its :class:`Result`.

    Parameters
    ----------
    scenario : a registered scenario name (``run_sim.py list``).
    overrides : ``{"object.mass_kg": 0.4}`` or ``["object.mass_kg=0.4"]``; applied after the preset.
        ``"controller.kind"`` picks any registered controller (:mod:`piezotip.controllers`, one
        registered by the calling script included); the other ``controller.*`` keys set its config.
    preset : ``fast``, ``balanced``, ``accurate``, ``reference`` or None.
    out : a folder to write the run's files into; None keeps everything in memory.
    plot : write ``run.png`` (only with ``out``).
    csv : write ``run.csv`` too (only with ``out``).
    video : write ``run.mp4`` (only with ``out``; ``video_fps`` frames per simulated second,
        ``video_size`` (width, height) in pixels; see the README's "Video").
    progress : show a progress bar.

    Raises
    ------
    KeyboardInterrupt
        Ctrl-C (SIGINT) stopped the run; SIGTERM raises :class:`piezotip.interrupts.Terminated`,
        a KeyboardInterrupt too, which uncaught ends the script with status 143 and no traceback.
        Either comes after the run's files are written (the recording so far and a summary marked
        ``"interrupted": true``, in ``out`` when given); its ``result`` is that partial
        :class:`Result` (None when the signal came before the run began), so a script's loop
        over runs stops there (:mod:`piezotip.interrupts`).
    """
    from piezotip import interrupts

    done: dict = {}  # what the run leaves, as it comes: its overrides and folder, then its summary and data
    files = {"plot": plot, "csv": csv, "video": video, "video_fps": video_fps, "video_size": video_size, "progress": progress}
    with interrupts.raised():  # SIGTERM as Ctrl-C, from the start (its default would end the process without the summary)
        try:
            _run_into(done, scenario, overrides, preset, out, **files)
            result = _result(scenario, preset, **done)
        except BaseException as err:  # a signal outside the run's loop: before it, or once its summary was written
            signum = interrupts.signal_in(err)
            if signum is None:
                raise
            if "summary" not in done:
                raise interrupts.caller_error(
                    signum, f"piezotip.run({scenario!r}) interrupted before the run began: nothing was written"
                ) from None
            raise interrupts.caller_error(
                signum, f"piezotip.run({scenario!r}) interrupted as it ended: its result is whole", _result(scenario, preset, **done)
            ) from None
        if result.summary["interrupted"]:  # the caller's loop stops here, as the command line's run does
            kept = f"the recording so far and summary.json are in {out}" if out is not None else "the exception's result holds them"
            signum = signal.Signals[result.summary["signal"] or "SIGINT"]
            raise interrupts.caller_error(signum, f"piezotip.run({scenario!r}): {result.reason}; {kept}", result)
        if interrupts.noted() is not None:  # a signal a library swallowed: the caller stops all the same
            raise interrupts.caller_error(
                interrupts.noted(), f"piezotip.run({scenario!r}) interrupted as it ended: its result is whole", result
            )
    return result


def _run_into(done: dict, scenario, overrides, preset, out, plot, csv, video, video_fps, video_size, progress) -> None:
    """:func:`run`'s run, what it leaves into ``done`` as it comes (``assignments`` and
    ``out_dir``, then ``summary`` and ``data``: :func:`_result`'s keywords)."""
    from piezotip.analysis.runner import run_scenario
    from piezotip.scenarios import override_strings

    done.update(assignments=override_strings(overrides), out_dir=None if out is None else Path(out))
    if out is None:
        if plot or csv or video:
            raise ValueError("plot=True, csv=True and video=True write files: give out=FOLDER")
        with tempfile.TemporaryDirectory(prefix="piezotip-run-") as tmp:
            summary, data = run_scenario(scenario, done["assignments"], Path(tmp), plot=False, quiet=not progress, preset=preset)
            done.update(data=dict(data), summary=dict(summary, files=[]))  # read before the folder goes
        return
    options = {"video": True, "video_fps": video_fps, "video_size": video_size} if video else {}
    summary, data = run_scenario(
        scenario, done["assignments"], done["out_dir"], csv=csv, plot=plot, quiet=not progress, preset=preset, **options
    )
    done.update(data=data, summary=summary)


def _result(scenario: str, preset: str | None, assignments: list[str], out_dir: Path | None, summary: dict, data) -> Result:
    events = tuple(MappingProxyType(dict(e)) for e in summary.get("events", []))
    return Result(scenario, tuple(assignments), preset, MappingProxyType(summary), MappingProxyType(dict(data)), events, out_dir)


def config(scenario: str = "grasp", overrides: Overrides = None, preset: str | None = None):
    """The scenario's whole validated :class:`~piezotip.scenarios.ScenarioConfig` (nothing run)."""
    from piezotip import scenarios

    return scenarios.get(scenario, overrides, preset)


def fingertip(scenario: str = "grasp", overrides: Overrides = None, preset: str | None = None):
    """The scenario's fingertip sensor (:class:`~piezotip.sensor.Fingertip`), as the loop builds it.

    A sensor designer's entry point: ``output(pressure_pa, mode)`` (eq. 21's normalized
    amplitude), ``resolution(pressure_pa, mode)``, ``detection_limit(mode)``,
    ``upper_limit(mode)``, ``mode_bands()``, ``dynamic_range()``, ``estimate(v1, mode)``.
    """
    from piezotip.cosim.instrument import make_fingertip

    return make_fingertip(config(scenario, overrides, preset))


def dynamic_range(scenario: str = "grasp", overrides: Overrides = None, preset: str | None = None) -> dict:
    """The scenario's fingertip's range: P_min, P_max (Pa), their ratio, per-mode limits and the
    switch pressures, as ``run_sim.py range --json`` reports them for that sensor."""
    return fingertip(scenario, overrides, preset).dynamic_range()


def scenario_names() -> list[str]:
    """The registered scenarios' names."""
    from piezotip import scenarios

    return scenarios.names()
