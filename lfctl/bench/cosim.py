"""lfctl bench cosim: the co-simulation master against a bare fmpy FMU2Slave loop.

For 1, 2, 10 and 50 SkidSteerRover vehicles at dt = 10 ms: microseconds per vehicle-step and
real-time factor of the master (scheduler + scripted commands at 20 Hz + world state), and in
the same run the bare fmpy loop (setReal, doStep, getReal per vehicle per step) over the same
FMU; ratio = master / baseline (below 1 means the master is faster than bare fmpy: fmpy's
setReal and getReal build their ctypes arrays at each call, the master once). Beside them the
floor: the same three C calls through arrays made once, in a plain loop, and the master over
it (what the master's scheduling, commands, world state and checks cost). Then the
master again with every FMU in a process of its own (``sim.fmu_process = "separate"``, the
default for a user FMU): what containing a crash costs, per step and per vehicle-step.
"""

from __future__ import annotations

import ctypes
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


def run_baseline(fmu: Path, n: int, duration_s: float, floor: bool = False) -> float:
    """Wall seconds for the bare fmpy loop (the documented FMU2Slave API); with ``floor``, the
    same fmi2SetReal, fmi2DoStep and fmi2GetReal called on the FMU's library through ctypes
    arrays made once, as the master calls them (nothing but the calls)."""
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
        if floor:
            return _floor_loop(slaves, vr_in, vr_out, steps)
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


def _floor_loop(slaves: list[FMU2Slave], vr_in: list[int], vr_out: list[int], steps: int) -> float:
    """Wall seconds for ``steps`` of the three calls per slave, straight into the library."""
    dll = slaves[0].dll
    set_real, do_step, get_real = dll.fmi2SetReal, dll.fmi2DoStep, dll.fmi2GetReal
    vin = (ctypes.c_uint32 * len(vr_in))(*vr_in)
    vout = (ctypes.c_uint32 * len(vr_out))(*vr_out)
    x = (ctypes.c_double * 2)(0.3, 0.1)
    y = (ctypes.c_double * len(vr_out))()
    n_in, n_out, dt = len(vr_in), len(vr_out), ctypes.c_double(DT_S)
    components = [s.component for s in slaves]
    t0 = time.perf_counter()
    t = 0.0
    for _ in range(steps):
        now = ctypes.c_double(t)
        for c in components:
            if set_real(c, vin, n_in, x) or do_step(c, now, dt, 1) or get_real(c, vout, n_out, y):
                raise RuntimeError(f"the floor loop's FMU call failed at t = {t:g} s")
        t += DT_S
    return time.perf_counter() - t0


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    fmu = build_model("SkidSteerRover").fmi2
    rows, results = [], []
    for n in (1, 2, 10, 50):
        duration = (5.0 if quick else 20.0) if n <= 10 else (2.0 if quick else 8.0)
        repeats = 1 if quick else 3
        times: dict[str, list[float]] = {"master": [], "base": [], "floor": [], "apart": []}
        for _ in range(repeats):  # (the cases in turn, each round: a slow phase falls on all of them)
            times["master"].append(run_master(n, duration))
            times["base"].append(run_baseline(fmu, n, duration))
            times["floor"].append(run_baseline(fmu, n, duration, floor=True))
            times["apart"].append(run_master(n, duration, "separate"))
        master, base, lowest, apart = (min(times[k]) for k in ("master", "base", "floor", "apart"))
        vehicle_steps = n * duration / DT_S
        m_us, b_us, f_us, a_us = (x / vehicle_steps * 1e6 for x in (master, base, lowest, apart))
        ratio = m_us / b_us
        step_cost_us = (apart - master) / (duration / DT_S) * 1e6
        rows.append(
            (
                n, duration, m_us, duration / master, b_us, duration / base, ratio, f_us, m_us / f_us, a_us,
                duration / apart, step_cost_us,
            )
        )  # fmt: skip
        results.append(
            {
                "vehicles": n,
                "sim_s": duration,
                "master_us_per_vehicle_step": round(m_us, 3),
                "master_real_time_factor": round(duration / master, 1),
                "fmpy_baseline_us_per_vehicle_step": round(b_us, 3),
                "fmpy_baseline_real_time_factor": round(duration / base, 1),
                "master_over_baseline_ratio": round(ratio, 3),
                "floor_us_per_vehicle_step": round(f_us, 3),
                "master_over_floor_ratio": round(m_us / f_us, 3),
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
            "floor us/veh-step",
            "master/floor",
            "separate us/veh-step",
            "separate RTF",
            "separate cost us/step",
        ),
        rows,
    )
    print(
        "fmpy: its FMU2Slave's setReal / doStep / getReal (ctypes arrays built at each call); floor: the same three "
        "C calls through arrays made once, nothing else (the master calls them so)"
    )
    print("separate: every FMU in a process of its own (sim.fmu_process); its cost per step is over the master's")
    print_json("cosim", results)


if __name__ == "__main__":
    run_as_script(main, __doc__)
