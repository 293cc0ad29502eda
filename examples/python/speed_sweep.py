#!/usr/bin/env python3
"""Sweeps the forward speed command of the NMPC trot in simulation and compares the speed
the robot reaches with the command.

    PYTHONPATH=build/python python3 examples/python/speed_sweep.py --out out/speed_sweep.png

Each run: the flat scene, the full control pipeline (NMPC + CBF-QP + integrator, the
default control settings with deterministic MPC timing), `--duration` seconds; the reached
speed is the base's mean world x velocity over the second half of the run.
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rollstep  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4],
                        help="forward commands [m/s]")
    parser.add_argument("--duration", type=float, default=4.0, help="simulated time per run [s]")
    parser.add_argument("--gait", default="trot", help="standing, rolling, trot or static_walk")
    parser.add_argument("--out", default="out/speed_sweep.png", help="figure file (PNG)")
    args = parser.parse_args()

    reached = []
    for vx in args.speeds:
        sim = rollstep.Simulation(scene="flat", controller="nmpc", gait=args.gait, command=(vx, 0.0, 0.0))
        sim.run(args.duration)
        log = sim.log()
        late = log["time"] >= args.duration / 2
        speed = float(np.mean(log["base_vx"][late]))
        reached.append(speed)
        print(f"speed_sweep: command {vx:.2f} m/s -> {speed:.3f} m/s "
              f"(base height {log['base_z'][late].mean():.3f} m)")

    fig, ax = plt.subplots(figsize=(5, 4))
    ax.plot(args.speeds, args.speeds, "k--", label="command")
    ax.plot(args.speeds, reached, "o-", label="reached")
    ax.set_xlabel("forward command [m/s]")
    ax.set_ylabel("mean forward speed [m/s]")
    ax.legend()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"speed_sweep: wrote {args.out}")
    ok = all(np.isfinite(reached)) and all(r > 0 for r in reached)
    print("speed_sweep: OK" if ok else "speed_sweep: FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
