#!/usr/bin/env python3
"""Checks the model's analytic derivatives against central finite differences with numpy:
the centroidal momentum h = A(q) v w.r.t. q, the generalized gravity w.r.t. q and a wheel's
position w.r.t. q (its LOCAL_WORLD_ALIGNED Jacobian).

    PYTHONPATH=build/python python3 examples/python/derivative_check.py

Derivatives w.r.t. q are along the tangent dq (integrate(q, dq)): the base part is a local
SE(3) perturbation, so a finite difference must step with integrate, not by adding to q.
"""
import numpy as np

import rollstep


def finite_difference(f, model, q, eps=1e-6):
    columns = []
    for e in np.eye(model.nv):
        columns.append((f(rollstep.integrate(model, q, eps * e)) - f(rollstep.integrate(model, q, -eps * e))) / (2 * eps))
    return np.column_stack(columns)


def main():
    model = rollstep.load_robot_model()
    data = rollstep.Data(model)
    rng = np.random.default_rng(0)
    q = rollstep.neutral_configuration(model)
    q[3:7] = rng.normal(size=4)
    q[3:7] /= np.linalg.norm(q[3:7])
    q[7:] = 0.5 * (model.lower_position_limit + model.upper_position_limit)
    v = rng.normal(size=model.nv)

    dh_dq, _ = rollstep.compute_centroidal_momentum_derivatives(model, data, q, v)
    fd_h = finite_difference(lambda qq: rollstep.compute_centroidal_momentum(model, data, qq, v), model, q)
    dg_dq = rollstep.compute_generalized_gravity_derivatives(model, data, q)
    fd_g = finite_difference(lambda qq: rollstep.compute_generalized_gravity(model, data, qq), model, q)
    rollstep.compute_joint_jacobians(model, data, q)
    J = rollstep.get_frame_jacobian(model, data, "LF_wheel", rollstep.ReferenceFrame.LOCAL_WORLD_ALIGNED)

    def wheel(qq):
        rollstep.forward_kinematics(model, data, qq)
        return rollstep.get_frame_placement(model, data, "LF_wheel")[:3, 3]

    fd_p = finite_difference(wheel, model, q)
    ok = True
    for name, analytic, fd in (("d h / dq", dh_dq, fd_h), ("d g / dq", dg_dq, fd_g),
                               ("d p_LF_wheel / dq", J[:3], fd_p)):
        error = np.abs(analytic - fd).max() / max(1.0, np.abs(analytic).max())
        print(f"derivative_check: {name:18s} relative error {error:.2e}")
        ok = ok and error < 1e-6
    print("derivative_check: OK" if ok else "derivative_check: FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
