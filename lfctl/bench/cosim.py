"""lfctl bench cosim: the co-simulation master against a bare fmpy FMU2Slave loop.

For 1, 2, 10 and 50 SkidSteerRover vehicles at dt = 10 ms: microseconds per vehicle-step and
real-time factor of the master (scheduler + scripted commands at 20 Hz + world state), and in
the same run the bare fmpy loop (setReal, doStep, getReal per vehicle per step) over the same
FMU; ratio = master / baseline (below 1 means the master is faster than bare fmpy). Then the
master again with every FMU in a process of its own (``sim.fmu_process = "separate"``, the
default for a user FMU): what containing a crash costs, per step and per vehicle-step.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.config import parse_config
from lfctl.fmu.build import build_model
from lfctl.sim.cosim import Simulation
from lfctl.sim.scripted import scripted_command

__all__ = ["main"]

DT_S = 0.01


def scenario(n: int, duration_s: float, fmu_process: str = "main") -> str:
    text = f"[sim]\ndt_s = {DT_S}\nduration_s = {duration_s}\nfmu_process = '{fmu_process}'\n"
    for i in range(n):
        role = "leader" if i == 0 else "follower"
        text += f'[[vehicles]]\nname = "v{i}"\nrole = "{role}"\neast_m = {i * 2.0}\n'
    return text


def run_master(n: int, duration_s: float, fmu_process: str = "main") -> float:
    """Wall seconds for the master to run n vehicles for duration_s (their FMUs where
    ``fmu_process`` says)."""
    cfg = parse_config(scenario(n, duration_s, fmu_process), "bench")
    with Simulation(cfg) as sim:

        def script(t_s: float) -> None:
            v, r = scripted_command(cfg.script, t_s)
            for i in range(n):
                sim.set_command(i, v, r)

        sim.add_task("script", 20.0, script)
        return sim.run().wall_time_s


def run_baseline(fmu: Path, n: int, duration_s: float) -> float:
    """Wall seconds for the bare fmpy loop (the documented FMU2Slave API)."""
    md = read_model_description(str(fmu))
    unzipdir = extract(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    vr_in = [vr["speed_cmd"], vr["yaw_rate_cmd"]]
    vr_out = [vr[k] for k in ("north", "east", "yaw", "speed", "yaw_rate")]
    slaves = []
    try:
        for i in range(n):
            s = FMU2Slave(
                guid=md.guid,
                unzipDirectory=unzipdir,
                modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName=f"v{i}",
            )
            s.instantiate()
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            s.exitInitializationMode()
            slaves.append(s)
        steps = round(duration_s / DT_S)
        t0 = time.perf_counter()
        t = 0.0
        for _ in range(steps):
            for s in slaves:
                s.setReal(vr_in, [0.3, 0.1])
                s.doStep(t, DT_S)
                s.getReal(vr_out)
            t += DT_S
        return time.perf_counter() - t0
    finally:
        for s in slaves:
            s.terminate()
            s.fmi2FreeInstance(s.component)
        shutil.rmtree(unzipdir, ignore_errors=True)


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    fmu = build_model("SkidSteerRover").fmi2
    rows, results = [], []
    for n in (1, 2, 10, 50):
        duration = (5.0 if quick else 20.0) if n <= 10 else (2.0 if quick else 8.0)
        repeats = 1 if quick else 3
        master = min(run_master(n, duration) for _ in range(repeats))
        base = min(run_baseline(fmu, n, duration) for _ in range(repeats))
        apart = min(run_master(n, duration, "separate") for _ in range(repeats))
        vehicle_steps = n * duration / DT_S
        m_us, b_us, a_us = (x / vehicle_steps * 1e6 for x in (master, base, apart))
        ratio = m_us / b_us
        step_cost_us = (apart - master) / (duration / DT_S) * 1e6
        rows.append(
            (n, duration, m_us, duration / master, b_us, duration / base, ratio, a_us, duration / apart, step_cost_us)
        )
        results.append(
            {
                "vehicles": n,
                "sim_s": duration,
                "master_us_per_vehicle_step": round(m_us, 3),
                "master_real_time_factor": round(duration / master, 1),
                "fmpy_baseline_us_per_vehicle_step": round(b_us, 3),
                "fmpy_baseline_real_time_factor": round(duration / base, 1),
                "master_over_baseline_ratio": round(ratio, 3),
                "separate_process_us_per_vehicle_step": round(a_us, 3),
                "separate_process_real_time_factor": round(duration / apart, 1),
                "separate_process_cost_us_per_step": round(step_cost_us, 2),
            }
        )
    print_table(
        (
            "vehicles",
            "sim s",
            "master us/veh-step",
            "master RTF",
            "fmpy us/veh-step",
            "fmpy RTF",
            "ratio master/fmpy",
            "separate us/veh-step",
            "separate RTF",
            "separate cost us/step",
        ),
        rows,
    )
    print("separate: every FMU in a process of its own (sim.fmu_process); its cost per step is over the master's")
    print_json("cosim", results)


if __name__ == "__main__":
    run_as_script(main, __doc__)
