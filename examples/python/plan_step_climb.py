#!/usr/bin/env python3
"""Plans a trot up the 20 cm step with the full-centroidal OCP and plots the plan.

    PYTHONPATH=build/python python3 examples/python/plan_step_climb.py --out out/plan_step.png

The OCP settings are the climb behaviour's (config/behaviours/climb.yaml, its `ocp:`
section); the horizon covers the whole climb (3 s), solved once in converging mode from
the standing state 0.4 m before the step's riser zone. The figure shows the base height,
each wheel centre's height and the vertical contact forces over the plan.
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
    parser.add_argument("--out", default="out/plan_step_climb.png", help="figure file (PNG)")
    parser.add_argument("--vx", type=float, default=0.3, help="forward command [m/s]")
    parser.add_argument("--duration", type=float, default=3.0, help="horizon [s]")
    args = parser.parse_args()

    control = rollstep.ControlSettings.load(os.path.join(rollstep.config_dir(), "behaviours", "climb.yaml"))
    settings = rollstep.OcpSettings(**control.ocp.to_dict())
    settings.horizon = int(round(args.duration / settings.dt))
    settings.solver.max_iterations = 300
    ocp = rollstep.CentroidalOcp(settings=settings, scene="step20", gait="trot",
                                 command=(args.vx, 0.0, 0.0), start=(0.4, 0.0, 0.0))
    status = ocp.solve()
    print(f"plan_step_climb: {status} after {ocp.iterations} iterations in {ocp.solve_time:.2f} s, "
          f"cost {ocp.cost:.4g}")
    t, x = ocp.times, ocp.states
    feet = ocp.foot_positions  # (N+1, nc, 3), world [m]
    forces = ocp.contact_forces  # (N, nc, 3), world [N]
    print(f"plan_step_climb: base from x = {x[0, 0]:.3f} m to {x[-1, 0]:.3f} m; "
          f"wheel centres at the end {np.round(feet[-1, :, 2], 3)} m")

    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 8))
    axes[0].plot(t, x[:, 2])
    axes[0].set_ylabel("base z [m]")
    for i, name in enumerate(ocp.contact_names):
        axes[1].plot(t, feet[:, i, 2], label=name)
        axes[2].plot(t[:-1], forces[:, i, 2], label=name)
    axes[1].set_ylabel("wheel centre z [m]")
    axes[2].set_ylabel("normal force [N]")
    axes[2].set_xlabel("time [s]")
    axes[1].legend(ncol=3, fontsize="small")
    fig.suptitle(f"Trot up step20 at {args.vx} m/s: {status}")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"plan_step_climb: wrote {args.out}")
    # The front wheels end on the block (0.2 m step + 0.075 m wheel radius).
    ok = status in ("Converged", "Acceptable") and feet[-1, 0, 2] > 0.25
    print("plan_step_climb: OK" if ok else "plan_step_climb: FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
