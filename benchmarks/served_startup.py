"""How long a scheduled run of the served nightly deployment takes to reach its assets.

    python -m benchmarks.served_startup --runs 5

The way production runs (issue 22, item 2): a Prefect server (``prefect server start``) and
``fleet-health serve`` serving the deployments, both started here in a demo work directory
(``fleet-health demo``: 3 vehicles, 6 days; its nightly runs leave every asset up to date). Each
measured run is a flow run of the ``nightly`` deployment scheduled ``--lead`` seconds ahead,
as its cron schedule would create it, so that the runner has it in hand before it is due.
From the server's records of each run:

* **due -> running**: the scheduled time to the flow run's start (the runner spawns a Python
  process that imports Prefect and the flow's module, and the engine sets the run Running);
* **running -> batch task**: the flow body before its first batch task starts (configuration,
  the run lock, discovery of the fleet);
* **due -> batch task**: the sum, the start-up before the first asset's work (the task then
  opens the registry and reads the first asset);
* **batch task**: the whole batch of up-to-date assets (registry opened, watermarks read);
* **due -> task end**: the scheduled time to the batch task's end, an upper bound of the time
  before the first asset's work (the registry is opened first, and the three up-to-date
  assets' reads take a few milliseconds each).

Prints each run and the medians; ``--json FILE`` keeps them.
"""
from __future__ import annotations

import argparse
import asyncio
import datetime
import json
import os
import pathlib
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

from benchmarks.measured_process import stop_on_signals
from benchmarks.nightly_scale import say

BIN = pathlib.Path(sys.executable).parent
REPO = pathlib.Path(__file__).resolve().parents[1]


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.served_startup",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="measured runs (default %(default)s)")
    parser.add_argument("--lead", type=float, default=40.0,
                        help="seconds ahead each run is scheduled (default %(default)s: more "
                             "than the runner's prefetch, 30 s, as for a cron schedule, whose "
                             "runs the server creates long before they are due)")
    parser.add_argument("--workdir", type=pathlib.Path,
                        help="work directory (default: a new temporary one, removed after)")
    parser.add_argument("--json", type=pathlib.Path, help="write the runs here")
    return parser.parse_args(argv)


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _wait(condition, what: str, timeout: float = 180.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.5)
    raise RuntimeError(f"timed out after {timeout:g} s waiting for {what}")


async def _measure(lead: float) -> dict:
    from prefect import get_client
    from prefect.client.schemas.filters import FlowRunFilter, FlowRunFilterId
    from prefect.states import Scheduled

    async with get_client() as client:
        deployment = await client.read_deployment_by_name("fleet-health-nightly/nightly")
        due = datetime.datetime.now(datetime.timezone.utc) + datetime.timedelta(seconds=lead)
        run = await client.create_flow_run_from_deployment(
            deployment.id, state=Scheduled(scheduled_time=due))
        deadline = time.monotonic() + lead + 180
        while time.monotonic() < deadline:
            run = await client.read_flow_run(run.id)
            if run.state is not None and run.state.is_final():
                break
            await asyncio.sleep(0.5)
        else:
            raise RuntimeError(f"flow run {run.id} did not finish")
        tasks = await client.read_task_runs(
            flow_run_filter=FlowRunFilter(id=FlowRunFilterId(any_=[run.id])))
    started = [t for t in tasks if t.start_time is not None]
    if run.start_time is None or not started:
        raise RuntimeError(f"flow run {run.id} ended {run.state_name} without a batch task")
    first = min(started, key=lambda t: t.start_time)
    seconds = lambda a, b: (b - a).total_seconds()          # noqa: E731
    return {"flow_run": str(run.id), "state": run.state_name,
            "due_to_running": seconds(run.expected_start_time, run.start_time),
            "running_to_task": seconds(run.start_time, first.start_time),
            "due_to_task": seconds(run.expected_start_time, first.start_time),
            "task": seconds(first.start_time, first.end_time) if first.end_time else None,
            "due_to_task_end": (seconds(run.expected_start_time, first.end_time)
                                if first.end_time else None)}


def main(argv=None) -> int:
    args = parse_args(argv)
    root = (args.workdir or pathlib.Path(tempfile.mkdtemp(prefix="served-startup-"))).resolve()
    demo = root / "demo"
    port = _free_port()
    api_url = f"http://127.0.0.1:{port}/api"
    env = dict(os.environ, PREFECT_HOME=str(root / "prefect-home"), PREFECT_API_URL=api_url,
               PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS="180")
    # this checkout first on the children's path (a relative PYTHONPATH would resolve against
    # the demo directory, and the installed package would be measured instead)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in env.get("PYTHONPATH", "")
                                                       .split(os.pathsep) if p])
    processes: list[subprocess.Popen] = []
    try:
        say(f"demo fleet in {demo} (about 40 s)")
        subprocess.run([str(BIN / "fleet-health"), "demo", "--workdir", str(demo), "--vehicles",
                        "3", "--days", "6", "--baseline-days", "4"], check=True,
                       env=dict(env, PREFECT_API_URL=""), stdout=subprocess.DEVNULL)
        # the demo's days are in the past: without this every asset is stale and each measured
        # run ends Failed ("not monitored") after its batch
        config = demo / "fleet.toml"
        config.write_text(config.read_text().replace('\nstale_after = "2D"',
                                                     '\nstale_after = "off"'))
        say(f"Prefect server on port {port}")
        processes.append(subprocess.Popen(
            [str(BIN / "prefect"), "server", "start", "--port", str(port)], env=env,
            stdout=(root / "server.log").open("w"), stderr=subprocess.STDOUT))
        def healthy() -> bool:
            try:
                with urllib.request.urlopen(f"{api_url}/health", timeout=2) as answer:
                    return answer.status == 200
            except OSError:
                return False

        _wait(healthy, "the Prefect server")
        say("fleet-health serve")
        processes.append(subprocess.Popen(
            [str(BIN / "fleet-health"), "serve"], cwd=demo, env=env,
            stdout=(root / "serve.log").open("w"), stderr=subprocess.STDOUT))
        _wait(lambda: "being served" in (root / "serve.log").read_text(), "the deployments")
        os.environ.update(PREFECT_API_URL=api_url, PREFECT_HOME=env["PREFECT_HOME"])
        runs = []
        for index in range(args.runs):
            run = asyncio.run(_measure(args.lead))
            runs.append(run)
            say(f"run {index + 1}: due -> running {run['due_to_running']:.2f} s, running -> "
                 f"batch task {run['running_to_task']:.2f} s, batch task {run['task']:.2f} s "
                 f"({run['state']})")
    finally:
        for process in reversed(processes):
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
        if args.workdir is None:
            shutil.rmtree(root, ignore_errors=True)
    print(f"served nightly deployment, {len(runs)} runs scheduled {args.lead:g} s ahead, "
          f"3 up-to-date assets; median seconds:")
    for key in ("due_to_running", "running_to_task", "due_to_task", "task", "due_to_task_end"):
        print(f"  {key.replace('_', ' ')}: {statistics.median(r[key] for r in runs):.2f}")
    if args.json:
        args.json.write_text(json.dumps(runs, indent=2))
    return 0


if __name__ == "__main__":
    stop_on_signals()   # the servers it starts are stopped in main()'s finally
    sys.exit(main())
