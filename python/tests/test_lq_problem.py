"""The solver on a user's LQ problem: the unconstrained problem against a Riccati recursion
in numpy, the constrained one against its KKT conditions, per-node data, checks."""
import numpy as np
import pytest

import rollstep


def double_integrator(N=20, dt=0.1):
    A = np.array([[1.0, dt], [0.0, 1.0]])
    B = np.array([[0.5 * dt * dt], [dt]])
    return A, B


def riccati(A, B, Q, R, QN, N, x0):
    P = QN
    K = []
    for _ in range(N):
        k = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        K.append(k)
        P = Q + A.T @ P @ (A - B @ k)
    K.reverse()
    xs, us = [x0], []
    for k in range(N):
        us.append(-K[k] @ xs[-1])
        xs.append(A @ xs[-1] + B @ us[-1])
    return np.array(xs), np.array(us), K


def test_unconstrained_equals_riccati():
    N = 20
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N)
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"
    xs, us, K = riccati(A, B, Q, R, QN, N, x0)
    np.testing.assert_allclose(lq.states, xs, atol=1e-9)
    np.testing.assert_allclose(lq.inputs, us, atol=1e-9)
    for k in (0, N // 2, N - 1):
        np.testing.assert_allclose(lq.feedback_gain(k), -K[k], atol=1e-8)
    with pytest.raises(IndexError, match="node 20 out of range"):
        lq.feedback_gain(N)


def test_bounds_and_rows_meet_kkt():
    N = 30
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    # |u| <= 2, velocity >= -0.6 as a general row on every node, final position in [-0.05, 0.05].
    C = [np.array([[0.0, 1.0]])] * N
    D = [np.zeros((1, 1))] * N
    lg = [np.array([-0.6])] * N
    ug = [np.array([np.inf])] * N
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N, u_bounds=([-2.0], [2.0]), C=C, D=D,
                            lg=lg, ug=ug, CN=np.array([[1.0, 0.0]]), lgN=[-0.05], ugN=[0.05])
    # Infeasible from 2.5 m: 30 nodes at 0.6 m/s cover 1.8 m at most.
    assert lq.solve(np.array([2.5, 0.0])) == "Infeasible"
    x0 = np.array([1.0, 0.0])
    lq.set_initial_guess(np.zeros((N + 1, 2)), np.zeros((N, 1)))
    assert lq.solve(x0) == "Converged"
    xs, us = lq.states, lq.inputs
    assert np.all(np.abs(us) <= 2.0 + 1e-7)
    assert np.all(xs[:-1, 1] >= -0.6 - 1e-7)
    assert abs(xs[-1, 0]) <= 0.05 + 1e-7
    # Active: the velocity row binds (an unconstrained solution would go faster).
    free = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N)
    free.solve(x0)
    assert free.states[:, 1].min() < -0.7
    assert xs[:, 1].min() == pytest.approx(-0.6, abs=1e-5)
    # Dynamics hold exactly (linear).
    np.testing.assert_allclose(xs[1:], xs[:-1] @ A.T + us @ B.T, atol=1e-10)
    # Optimality: no feasible perturbation along the free directions lowers the cost much.
    cost = lq.cost
    rng = np.random.default_rng(0)
    for _ in range(50):
        du = rng.normal(size=us.shape) * 1e-3
        u2 = np.clip(us + du, -2, 2)
        x = [x0]
        for k in range(N):
            x.append(A @ x[-1] + B @ u2[k])
        x = np.array(x)
        if np.all(x[:-1, 1] >= -0.6) and abs(x[-1, 0]) <= 0.05:
            c = sum(0.5 * x[k] @ Q @ x[k] + 0.5 * u2[k] @ R @ u2[k] for k in range(N)) + 0.5 * x[-1] @ QN @ x[-1]
            assert c >= cost - 1e-6


def test_time_varying_data_and_checks():
    N = 5
    A, B = double_integrator(N)
    As = np.stack([A * (1 + 0.01 * k) for k in range(N)])
    lq = rollstep.LqProblem(As, B, Q=np.eye(2), R=np.eye(1), QN=np.eye(2), c=[np.array([0.0, 0.1])] * N)
    assert lq.horizon == N
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"
    xs, us = lq.states, lq.inputs
    for k in range(N):
        np.testing.assert_allclose(xs[k + 1], As[k] @ xs[k] + B @ us[k] + [0.0, 0.1], atol=1e-10)
    with pytest.raises(ValueError, match=r"B\[0\] has shape \(3, 1\); expected \(2, 1\)"):
        rollstep.LqProblem(A, np.ones((3, 1)), horizon=3)
    with pytest.raises(ValueError, match="x0 has size 3"):
        lq.solve(np.zeros(3))
    with pytest.raises(ValueError, match="above upper"):
        rollstep.LqProblem(A, B, horizon=3, u_bounds=([1.0], [-1.0]))


def test_no_leak_over_many_problems():
    import resource
    A, B = double_integrator()

    def burst():
        for _ in range(100):
            lq = rollstep.LqProblem(A, B, Q=np.eye(2), R=np.eye(1), QN=np.eye(2), horizon=50,
                                    u_bounds=([-1.0], [1.0]))
            lq.solve(np.array([1.0, 0.0]))
            _ = lq.states, lq.inputs

    burst()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(3):
        burst()
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # 300 problems of 51 nodes: kept alive they take about 160 MB on this machine.
    assert after - before < 8000  # kB
