"""Planning in the observer's latent space: model-predictive control by shooting or iLQR, and LQR.

Both planners act on a trained run's robot through `litl.envs` (one environment step is one
control step: the action held for `loop.snapshot_stride` simulation steps, the step the latent
model was fitted on) and read the observer's latent z of the grid after each step and the true
position x of the point the robot's task steers (`Robot.task_point`: a walker's centroid, the
arm's tip). They plan with a `LatentModel` (`litl.latent.model`): z' = f(z, a) and the
velocity readout v(z), so a plan's predicted position is x_t = x_0 + Σ_{s<=t} Δ v(z_s)[axis].

Goals (`Goal`), goals the trained controller never saw:

* ``reach``: bring that point to `value` along the axis and stop there. Cost of a plan of H
  actions: (1/H) Σ_t (x_t − value)² + stop · (H Δ)² |v(z_H)|² + action_cost · mean(a²), in units
  of length².
* ``walk``: walk in the direction sign(`value`) (+1: +x, −1: −x). Cost: −sign · (x_H − x_0) / (H Δ)
  (the plan's mean speed) + action_cost · mean(a²).

`mpc_step` improves a plan (H, m) of logits (actions are tanh of them, in [-1, 1]) by
`MPCSettings.iterations` Adam steps on that cost (optax), warm-started by the previous plan
shifted by one step; `control` re-plans every `replan_every` control steps inside one
`lax.scan` (no Python loop per control step). `lqr_gains` steers the linear model augmented with
the position, s = (z, x): x' = x + Δ (Wᵀ(A z + B a + c) + b)[axis], an affine system, to
(z_rest, value) by `litl.latent.lqr.solve`, applied as a receding horizon (the first gain at every
step). `ilqr_step` minimizes the shooting cost by iLQR (`litl.latent.ilqr`) on s = (z, x)
instead, re-planned and warm-started the same way. The count of model evaluations per control
step is part of the result. With `oracle`,
the same MPC plans through the simulator itself (`true_plan_cost`): the reference that says
what the held actions can do at all, at H (iterations + 1) · hold simulation steps per control
step, each differentiated.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax
import jax.numpy as jnp
import optax

from litl.errors import UserError
from litl.latent.ilqr import STEPS, ilqr
from litl.latent.lqr import LQRProblem, solve
from litl.latent.model import LatentModel, linear_part
from litl.settings import Settings

GOALS = ("reach", "walk")
# Where a shooting MPC's re-planning starts (`MPCSettings.warm_start`).
WARM_STARTS = ("previous", "trained", "better")
# A guide's actions in [-1, 1] become the plan's logits through arctanh, clipped here.
GUIDE_LIMIT = 0.99


class GoalError(UserError, ValueError):
    """A goal litl cannot plan for; the message says what is wrong and what is allowed."""


@dataclasses.dataclass(frozen=True)
class Goal:
    """A task the planner is given (see the module docstring).

    Attributes:
      kind: ``"reach"`` or ``"walk"``.
      value: reach: the target position along `axis` (domain units); walk: the direction (+1, −1).
      axis: which coordinate of the task point (0: x).
    """

    kind: str
    value: float
    axis: int = 0

    @classmethod
    def parse(cls, text: str) -> Goal:
        """``"reach:0.6"`` or ``"walk:-1"``."""
        kind, _, value = str(text).partition(":")
        try:
            number = float(value)
        except ValueError:
            raise GoalError(
                f"goal {text!r}: write KIND:VALUE, reach:<x position> or walk:<+1 or -1>"
            ) from None
        goal = cls(kind, number)
        goal.check()
        return goal

    def check(self, bounds: tuple[float, float] | None = None) -> None:
        """GoalError for an unknown kind, a non-finite value, a walk direction other than ±1, or
        (given the domain's `bounds` along the axis) a reach target outside them."""
        if self.kind not in GOALS:
            raise GoalError(f"goal kind {self.kind!r}: choose one of {GOALS}")
        if not math.isfinite(self.value):
            raise GoalError(f"goal {self.kind}:{self.value}: the value must be finite")
        if self.kind == "walk" and self.value not in (1.0, -1.0):
            raise GoalError(f"goal walk:{self.value:g}: the direction is +1 or -1")
        if self.kind == "reach" and bounds is not None:
            low, high = bounds
            if not low < self.value < high:
                raise GoalError(
                    f"goal reach:{self.value:g}: the target lies outside the domain along axis "
                    f"{self.axis}, ({low:g}, {high:g}); choose a position inside it"
                )


@dataclasses.dataclass(frozen=True)
class MPCSettings(Settings):
    """Model-predictive control by gradient-based shooting through the latent model
    (`controller=latent_mpc`).

    Attributes:
      horizon: H, control steps planned ahead.
      iterations: Adam steps on the plan at each re-planning.
      learning_rate: Adam's step size on the plan's logits.
      replan_every: control steps between re-plannings (1: every step).
      action_cost: weight of mean(a²) in the cost.
      stop: reach goals: weight of the predicted final speed's term.
      model: the latent model planned through, ``mlp`` or ``linear``.
      warm_start: where each re-planning starts (`WARM_STARTS`): ``previous``, the last plan
        shifted by one step; ``trained``, the run's trained controller's actions rolled forward
        from the current latent through the model (through the simulator for the oracle);
        ``better``, whichever of the two the cost prefers.
    """

    KEY = "controller.latent_mpc"
    horizon: int = 10
    iterations: int = 30
    learning_rate: float = 0.3
    replan_every: int = 1
    action_cost: float = 1e-4
    stop: float = 1.0
    model: str = "mlp"
    warm_start: str = "previous"

    def check(self) -> None:
        self._positive_ints("horizon", "iterations", "replan_every")
        self._positive_numbers("learning_rate")
        self._positive_numbers("action_cost", "stop", zero=True)
        if self.model not in ("mlp", "linear"):
            self._invalid("model", "must be mlp or linear")
        if self.warm_start not in WARM_STARTS:
            self._invalid("warm_start", f"must be one of {', '.join(WARM_STARTS)}")


@dataclasses.dataclass(frozen=True)
class LQRSettings(Settings):
    """Receding-horizon LQR on the linear latent model augmented with the position
    (`controller=latent_lqr`; reach goals only).

    Attributes:
      horizon: control steps of the Riccati recursion (its first gain is applied at every step).
      action_cost: R = action_cost · I.
      latent_cost: Q's weight on z − z_rest (keeps the latent near the robot's rest).
      stop: Qf's weight on z − z_rest at the horizon.
    """

    KEY = "controller.latent_lqr"
    horizon: int = 20
    action_cost: float = 1e-4
    latent_cost: float = 1e-6
    stop: float = 1e-4

    def check(self) -> None:
        self._positive_ints("horizon")
        self._positive_numbers("action_cost")
        self._positive_numbers("latent_cost", "stop", zero=True)


@dataclasses.dataclass(frozen=True)
class ILQRSettings(Settings):
    """Receding-horizon iLQR through the latent model (`controller=latent_ilqr`,
    `litl.latent.ilqr`): the same cost as `latent_mpc` (reach and walk goals), minimized over the
    plan's tanh logits by iLQR on the position-augmented state s = (z, x) instead of Adam steps.

    Attributes:
      horizon: H, control steps planned ahead.
      iterations: iLQR iterations at each re-planning (each a backward pass and a line search
        over `litl.latent.ilqr.STEPS`).
      replan_every: control steps between re-plannings (1: every step).
      action_cost: weight of mean(a²) in the cost.
      stop: reach goals: weight of the predicted final speed's term.
      regularization: the floor of Q_uu's eigenvalues.
      model: the latent model planned through, ``mlp`` or ``linear``.
    """

    KEY = "controller.latent_ilqr"
    horizon: int = 10
    iterations: int = 5
    replan_every: int = 1
    action_cost: float = 1e-4
    stop: float = 1.0
    regularization: float = 1e-6
    model: str = "mlp"

    def check(self) -> None:
        self._positive_ints("horizon", "iterations", "replan_every")
        self._positive_numbers("regularization")
        self._positive_numbers("action_cost", "stop", zero=True)
        if self.model not in ("mlp", "linear"):
            self._invalid("model", "must be mlp or linear")


# ---------------------------------------------------------------------------------------------
# Shooting MPC


def goal_cost(
    positions, start, final_velocity, actions, duration, goal: Goal, settings: MPCSettings | ILQRSettings
):
    """() a plan's cost (the module docstring's) from its positions (H,) along the goal's axis,
    the start's, the velocity (d,) at its end, its actions (H, m) and its duration (s)."""
    effort = settings.action_cost * jnp.mean(actions**2)
    if goal.kind == "reach":
        stopping = settings.stop * duration**2 * jnp.sum(final_velocity**2)
        return jnp.mean((positions - goal.value) ** 2) + stopping + effort
    return -jnp.sign(goal.value) * (positions[-1] - start) / duration + effort


def plan_cost(logits, latent, position, model: LatentModel, goal: Goal, settings: MPCSettings | ILQRSettings):
    """() the cost of the plan `logits` (H, m) through the latent model from latent z (r,) and
    position x (), and the predicted (positions (H,), latents (H, r))."""
    actions = jnp.tanh(logits)
    dt = model.control_dt

    def forward(carry, action):
        z, x = carry
        z = model.step(z, action)
        x = x + dt * model.velocity(z)[goal.axis]
        return (z, x), (z, x)

    (last, _), (latents, positions) = jax.lax.scan(forward, (latent, position), actions)
    duration = logits.shape[0] * dt
    cost = goal_cost(positions, position, model.velocity(last), actions, duration, goal, settings)
    return cost, (positions, latents)


def true_plan_cost(logits, env, env_params, state, goal: Goal, settings: MPCSettings, key):
    """() the cost of the plan `logits` (H, m) through the simulator itself from the environment
    state `state` (the oracle: MPC through the true differentiable simulation)."""
    actions = jnp.tanh(logits)

    def forward(state, action):
        state = env.step_env(key, state, action, env_params)[1]
        return state, _robot(env, state)

    last, positions = jax.lax.scan(forward, state, actions)
    positions = positions[:, goal.axis]
    duration = logits.shape[0] * env_params.hold * env.robot.config.dt
    velocity = env.robot.task_point_velocity(last.sim)
    start = _robot(env, state)[goal.axis]
    return goal_cost(positions, start, velocity, actions, duration, goal, settings)


def _robot(env, state):
    """(d,) the point the robot's task steers in an environment state (`Robot.task_point`: its
    centroid, or the arm's tip's)."""
    return env.robot.task_point(state.sim)


def mpc_step(logits, cost, settings: MPCSettings):
    """(the improved plan, its cost before and after): `settings.iterations` Adam steps on
    `cost(logits) -> ()` (`plan_cost` or `true_plan_cost` with the rest bound) from `logits`."""
    adam = optax.adam(settings.learning_rate)
    value_and_grad = jax.value_and_grad(cost)

    def improve(carry, _):
        plan, state = carry
        value, grad = value_and_grad(plan)
        updates, state = adam.update(grad, state, plan)
        return (optax.apply_updates(plan, updates), state), value

    (plan, _), costs = jax.lax.scan(improve, (logits, adam.init(logits)), None, length=settings.iterations)
    return plan, costs[0], cost(plan)


def ilqr_step(logits, latent, position, model: LatentModel, goal: Goal, settings: ILQRSettings):
    """(the improved plan, its cost before and after): `settings.iterations` iLQR iterations on
    `plan_cost`'s objective, written in stage form on s = (z, x): per step (1/H)(x_t − value)²
    (reach) and action_cost · mean(a_t²) / H; at the end the same position term and the stop term
    (reach), or −sign · (x_H − x_0) / (H Δ) (walk). The first step's position term is a constant
    and left out."""
    horizon, dt = logits.shape[0], model.control_dt
    duration = horizon * dt

    def dynamics(s, u):
        z = model.step(s[:-1], jnp.tanh(u))
        return jnp.concatenate([z, (s[-1] + dt * model.velocity(z)[goal.axis])[None]])

    def effort(u):
        return settings.action_cost * jnp.mean(jnp.tanh(u) ** 2) / horizon

    if goal.kind == "reach":
        stage = lambda s, u, t: jnp.where(t > 0, (s[-1] - goal.value) ** 2 / horizon, 0.0) + effort(u)

        def final(s):
            speed = jnp.sum(model.velocity(s[:-1]) ** 2)
            return (s[-1] - goal.value) ** 2 / horizon + settings.stop * duration**2 * speed

    else:
        stage = lambda s, u, t: effort(u)
        final = lambda s: -jnp.sign(goal.value) * (s[-1] - position) / duration
    initial = jnp.concatenate([latent, position[None]])
    better, _, _ = ilqr(dynamics, stage, final, initial, logits, settings.iterations, settings.regularization)
    cost = lambda u: plan_cost(u, latent, position, model, goal, settings)[0]
    return better, cost(logits), cost(better)


def guided_plan(guide, latent, time, horizon: int, model: LatentModel):
    """(H, m) logits of the actions `guide(z, t) -> (m,)` (a trained controller) takes when rolled
    forward from latent z at time t (s) through the latent model."""

    def forward(z, k):
        action = guide(z, time + k * model.control_dt)
        return model.step(z, action), action

    _, actions = jax.lax.scan(forward, latent, jnp.arange(horizon))
    return jnp.arctanh(jnp.clip(actions, -GUIDE_LIMIT, GUIDE_LIMIT))


def guided_true_plan(guide, obs, state, horizon: int, env, env_params, key):
    """(H, m) logits of the actions `guide` takes when rolled forward through the simulator from
    the environment state (the oracle's warm start)."""
    r = obs.shape[0] - 2  # the observation is the observer's features and the clock
    dt = env.robot.config.dt

    def forward(carry, _):
        obs, state = carry
        action = guide(obs[:r], state.sim.step * dt)
        obs, state = env.step_env(key, state, action, env_params)[:2]
        return (obs, state), action

    _, actions = jax.lax.scan(forward, (obs, state), None, length=horizon)
    return jnp.arctanh(jnp.clip(actions, -GUIDE_LIMIT, GUIDE_LIMIT))


def warm_start(plan, cost, settings: MPCSettings, guided):
    """Where a re-planning starts (`MPCSettings.warm_start`): the shifted previous `plan`, the
    trained controller's `guided` plan, or the one of the two with the lower `cost`."""
    if settings.warm_start == "previous":
        return plan
    guided = guided.astype(plan.dtype)
    if settings.warm_start == "trained":
        return guided
    return jnp.where(cost(guided) < cost(plan), guided, plan)


def shift(plan):
    """The warm start for the next control step: the plan without its first action, its last
    action repeated."""
    return jnp.concatenate([plan[1:], plan[-1:]])


# ---------------------------------------------------------------------------------------------
# LQR on the position-augmented linear model


def augmented_problem(model: LatentModel, goal: Goal, rest_latent, settings: LQRSettings) -> LQRProblem:
    """The LQR problem of s = (z, x) with x' = x + Δ v(z')[axis] (see the module docstring)."""
    if goal.kind != "reach":
        raise GoalError(f"goal {goal.kind}: latent_lqr plans reach goals only (latent_mpc plans walk)")
    linear = linear_part(model)
    r, m = linear.B.shape
    dt = model.control_dt
    w, b = model.readout[:, goal.axis], model.offset[goal.axis]
    A = jnp.block([[linear.A, jnp.zeros((r, 1))], [dt * (w @ linear.A)[None], jnp.ones((1, 1))]])
    B = jnp.concatenate([linear.B, dt * (w @ linear.B)[None]])
    c = jnp.concatenate([linear.c, (dt * (w @ linear.c + b))[None]])
    dtype = linear.A.dtype
    weights = jnp.concatenate([jnp.full(r, settings.latent_cost, dtype), jnp.ones(1, dtype)])
    final = jnp.concatenate([jnp.full(r, settings.stop, dtype), jnp.ones(1, dtype)])
    target = jnp.concatenate([rest_latent.astype(dtype), jnp.full(1, goal.value, dtype)])
    return LQRProblem(
        A=A,
        B=B,
        c=c,
        Q=jnp.diag(weights),
        R=settings.action_cost * jnp.eye(m, dtype=dtype),
        Qf=jnp.diag(final),
        target=target,
    )


# ---------------------------------------------------------------------------------------------
# A whole episode under a planner, in the environment


def _policy(
    env, env_params, model: LatentModel, goal: Goal, settings, key, rest_latent, oracle: bool, policy
):
    """act(obs, state, plan, t) -> (plan, action, its cost, whether it re-planned): the planner's
    choice at control step t (see `control`)."""
    r = model.latent_size
    where = lambda state: _robot(env, state)[goal.axis]
    if isinstance(settings, LQRSettings):
        problem = augmented_problem(model, goal, rest_latent, settings)
        solution = solve(problem, settings.horizon)
        gain, offset = solution.gains[0], solution.offsets[0]

        def act(obs, state, plan, t):
            s = jnp.concatenate([obs[:r], where(state)[None]])
            action = -gain @ (s - problem.target) - offset
            return plan, jnp.clip(action, -1, 1), solution.cost_to_go(s, problem.target), jnp.array(True)

    else:
        every = settings.replan_every
        horizon = settings.horizon

        def guided(obs, state):
            if oracle:
                return guided_true_plan(policy, obs, state, horizon, env, env_params, key)
            time = state.sim.step * env.robot.config.dt
            return guided_plan(policy, obs[:r], time, horizon, model)

        def act(obs, state, plan, t):
            if oracle:
                cost = lambda u: true_plan_cost(u, env, env_params, state, goal, settings, key)
            else:
                cost = lambda u: plan_cost(u, obs[:r], where(state), model, goal, settings)[0]

            def replan(plan):
                if getattr(settings, "warm_start", "previous") != "previous":
                    plan = warm_start(plan, cost, settings, guided(obs, state))
                if isinstance(settings, ILQRSettings):
                    better, _, after = ilqr_step(plan, obs[:r], where(state), model, goal, settings)
                else:
                    better, _, after = mpc_step(plan, cost, settings)
                return better, after

            replans = t % every == 0
            plan, cost = jax.lax.cond(replans, replan, lambda p: (p, jnp.full((), jnp.nan, p.dtype)), plan)
            return plan, jnp.tanh(plan[0]), cost, replans

    return act


def control(
    env,
    env_params,
    model: LatentModel,
    goal: Goal,
    settings,
    key,
    steps: int | None = None,
    oracle: bool = False,
    guide=None,
) -> dict:
    """One episode of `env` (a trained run's environment, `litl.replay.environment`, with
    ``hold`` the model's control step) under the planner `settings` (`MPCSettings` or
    `LQRSettings`) toward `goal`. Pure and jittable with `goal`, `settings`, `steps` and `oracle`
    static. `oracle`: MPC plans through the simulator itself (`true_plan_cost`), not the model
    (the model then only gives `predicted`). `guide(z, t) -> (m,)`: the run's trained controller
    (features and time to actions), from which `MPCSettings.warm_start` ``trained`` and
    ``better`` start each re-planning.

    Returns:
      positions (T + 1,) the task point along the goal's axis from the start; predicted (T,) the
      model's position one control step after each action (from the true position and latent);
      particles (T, n, d) the robot's particles after each control step; actions (T, m);
      planned_cost (T,) the plan's cost after planning (MPC; NaN at steps that did not re-plan)
      or the cost-to-go of the state (LQR);
      nonfinite (T,) bool where the plan's prediction was not finite (the action is then 0).
    """
    steps = env_params.max_steps if steps is None else steps
    r = model.latent_size
    where = lambda state: _robot(env, state)[goal.axis]
    obs, state = env.reset(key, env_params)
    m = env.num_actions
    if getattr(settings, "warm_start", "previous") != "previous" and guide is None:
        raise ValueError(f"warm_start={settings.warm_start!r} needs the trained controller: pass guide")
    act = _policy(env, env_params, model, goal, settings, key, obs[:r], oracle, guide)
    horizon = getattr(settings, "horizon", 1)
    plan0 = jnp.zeros((horizon, m), obs.dtype)

    def one(carry, t):
        obs, state, plan = carry
        plan, action, cost, replanned = act(obs, state, plan, t)
        # A plan whose prediction is not finite is not acted on (its action is 0, and it is named).
        finite = jnp.all(jnp.isfinite(action)) & jnp.all(jnp.isfinite(plan))
        finite = finite & (~replanned | jnp.isfinite(cost))
        action = jnp.where(finite, action, 0.0)
        plan = jnp.where(finite, plan, 0.0)
        # What the model expects of the action it chose: the position one control step later.
        predicted = where(state) + model.control_dt * model.velocity(model.step(obs[:r], action))[goal.axis]
        obs, state, _, _, _ = env.step_env(key, state, action, env_params)
        particles = env.robot.own(state.sim).x
        return (obs, state, shift(plan)), (where(state), predicted, action, cost, ~finite, particles)

    start = where(state)
    _, (positions, predicted, actions, costs, nonfinite, particles) = jax.lax.scan(
        one, (obs, state, plan0), jnp.arange(steps)
    )
    return {
        "positions": jnp.concatenate([start[None], positions]),
        "particles": particles,
        "predicted": predicted,
        "actions": actions,
        "planned_cost": costs,
        "nonfinite": nonfinite,
    }


def model_steps(settings) -> float:
    """Model evaluations (forward passes) of one control step's planning: H (iterations + 1) per
    re-planning for MPC (its gradients add about twice that); for iLQR H (1 + iterations (1 +
    line-search steps)) forward passes plus H · iterations Jacobians; 0 for LQR (solved once per
    episode: `horizon` Riccati steps). A warm start by the trained controller adds H (``trained``)
    or 3H (``better``: its rollout and both plans' costs)."""
    if isinstance(settings, MPCSettings):
        # the trained controller's rollout through the model; for `better` both plans' costs too
        warm = {"previous": 0, "trained": 1, "better": 3}[settings.warm_start]
        return settings.horizon * (settings.iterations + 1 + warm) / settings.replan_every
    if isinstance(settings, ILQRSettings):
        passes = 1 + settings.iterations * (1 + len(STEPS))
        return settings.horizon * passes / settings.replan_every
    return 0.0


def first_nonfinite(nonfinite) -> int | None:
    """The first control step whose plan was not finite, or None."""
    import numpy as np

    steps = np.flatnonzero(np.asarray(nonfinite))
    return int(steps[0]) if steps.size else None


PLANNERS: dict[str, Any] = {"latent_mpc": MPCSettings, "latent_ilqr": ILQRSettings, "latent_lqr": LQRSettings}
