"""The zoo's section of docs/benchmarks.md (between its markers; the rest of the page is kept)."""
from __future__ import annotations

import pathlib
import re

BEGIN, END = "<!-- zoo:begin -->", "<!-- zoo:end -->"


#: kinds of a failed read the product takes for a machine that did not run: an idle day
#: (``no_data``: the asset's idle status) and one that ran too little to read
#: (``too_few_samples``: left out of a baseline, a night not monitored), each with a note
IDLE_READS = ("no_data", "too_few_samples")
#: how such a read's message ends (``str`` of a TelemetryError names its kind in brackets)
_IDLE_ENDINGS = tuple(f"[{kind}]" for kind in IDLE_READS)


def idle_read(message: str) -> bool:
    """Whether a failed read's message is of one of :data:`IDLE_READS`: a day the product
    takes for a machine that did not run (left out of a baseline, a night not monitored)."""
    return message.rstrip().endswith(_IDLE_ENDINGS)


def failure_counts(result: dict) -> tuple[int, int]:
    """A family result's failures and its days not operating.

    A read that failed with one of :data:`IDLE_READS` (its message ends in the kind in
    brackets, as ``str`` of a :class:`graybox.exceptions.TelemetryError` does) and a night
    settled by :func:`benchmarks.zoo.run.night_not_operating` (``calm_nights``) are days the
    product reports as not operating, not failures; every other failed read, baseline and
    night is a failure.
    """
    idle = sum(map(idle_read, result["failed_reads"].values()))
    failures = sum(len(result[k]) for k in ("failed_reads", "failed_baselines", "failed_nights"))
    return failures - idle, idle + len(result.get("calm_nights", {}))


def share(part: int, whole: int) -> str:
    """``part/whole = N %`` (``-`` for none)."""
    return f"{part}/{whole} = {100 * part / whole:.0f} %" if whole else "-"


def false_alarm_cell(figure: dict) -> str:
    """A false-alarm figure (:func:`benchmarks.detection.metrics.rate`) as ``a/n = r %
    (low-high %)`` (``-`` for no asset-nights)."""
    low, high = figure["interval"]
    if not figure["asset_nights"]:
        return "-"
    return (f"{figure['alarms']}/{figure['asset_nights']} = {100 * figure['rate']:.2f} % "
            f"({100 * low:.2f}-{100 * high:.2f} %)")


def _tiers(counts: dict) -> str:
    return ", ".join(f"{k}: {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1])) or "none"


def markdown(results: list[dict], command: str, notes: str = "") -> str:
    """The section: one row per family, then one row per fault kind and magnitude."""
    rows = []
    for r in results:
        failures, calm = failure_counts(r)
        rows.append(
            f"| {r['title']} | {'held out' if r['held_out'] else 'tuning'} | "
            f"{r['baselines_fitted']}/{r['healthy_assets']} | "
            f"{share(*r['detected_small'])} | {share(*r['detected_large'])} | {false_alarm_cell(r['false_alarms'])} | "
            f"{_tiers(r['healthy_tiers'])} | {r['s_per_night']:.2f} | "
            f"{r['s_per_baseline_day']:.2f} | {100 * r['needed_share']:.0f} % | {failures} | {calm} |")
    faults = []
    for r in results:
        for (kind, size), d in r["detection"].items():
            faults.append(f"| {r['family']} | {kind} | {size} | {share(d['detected'], d['assets'])} | "
                          f"{d['alarmed_before_onset']} | {_tiers(d['tiers'])} |")
    failures = []
    for r in results:
        for key in ("failed_reads", "failed_baselines", "failed_nights"):
            for what, message in list(r[key].items())[:3]:
                failures.append(f"- {r['family']} {key.replace('_', ' ')}: {what}: {message}")
    first = results[0] if results else {}
    return f"""{BEGIN}
## The plant zoo: defaults on plants this project did not write

Each family is a plant simulated by its own code under `benchmarks/zoo/families/` (never the
project's simulator or white boxes), with its own operating profile that differs from day to
day, disturbances, process and sensor noise, and a coarse white box written as a user would
(parameters 10-20 % off, simplified structure, effects left out). A family gets only its white
box, column map and channel roles (and, for a machine that stops, its fleet.toml `grid` line):
every fit runs with the product's defaults. Protocol: {first.get('healthy_assets', '-')}
healthy vehicles per family, a {first.get('baseline_days', '-')}-day baseline each (target
1 % false alarms per asset-night), then {first.get('nights', '-')} scored nights; per fault
kind and magnitude {first.get('faulty_per_cell', '-')} faulty assets that share a vehicle's
seed and baseline (identical telemetry up to the onset, inside the first scored night), scored
on the three nights from the onset; candidates of {first.get('candidate_nights', '-')}
nights, as `[nightly] candidate_nights`; telemetry through the store layout and
`graybox.read_window`. "Tuning" families were used to choose defaults; "held out" ones were not.
A day the product reports as `not operating` (not monitored, with a note) is counted under
"days not operating", neither scored nor a failure: a day whose read finds the machine idle
(`no_data`) or running too little to read (`too_few_samples`), and a night whose window ran
too little to fit.

| family | role | baselines | small faults within 3 nights | large faults within 3 nights | false alarms per healthy asset-night (95 % CI) | healthy alarms by channel/tier | s per asset-night | s per asset-day of baseline | channels needing the network | failures | days not operating |
|---|---|---|---|---|---|---|---|---|---|---|---|
{chr(10).join(rows)}

| family | fault | magnitude | detected within 3 nights | alarmed before onset | first alarm's channel/tier |
|---|---|---|---|---|---|
{chr(10).join(faults)}

{chr(10).join(failures) if failures else "No read, baseline or night failed."}

Command: `{command}`{(chr(10) + chr(10) + notes) if notes else ""}
{END}"""


def write_section(path: str | pathlib.Path, section: str) -> None:
    """Replace the zoo section of ``path`` (append it when absent)."""
    path = pathlib.Path(path)
    text = path.read_text() if path.exists() else ""
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: section, text)
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    path.write_text(text)
