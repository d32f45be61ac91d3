"""Evolution strategies (evosax) on what litl's gradients optimize: the controller network θ and the
design φ, in the design space of the run (`design=`): the Young's modulus per region in units of its
range, and, for the body's spaces, each particle's occupancy (in [0, 1]) and its actuator logits
(in units of their starting sharpness), each kept in its bounds as the loop keeps it
(`DesignUnits`). The design's costs (volume, grayness) count in a candidate's fitness as in the
loop's loss.

``cmaes``: CMA-ES with evosax's defaults but the initial step size `sigma` (its covariance is n x n
for n parameters, decomposed every generation: at the biped's MLP, n = 6152, a generation takes
seconds per seed on a CPU); ``sep_cmaes``: separable CMA-ES (Ros & Hansen 2008, a diagonal
covariance: linear in n, the variant meant for networks), likewise; ``openai_es``: OpenAI-ES with
mirrored sampling, standard deviation `sigma` and Adam at `learning_rate` on the mean. Each has its
own settings (``optimizer.cmaes.population`` and so on). One strategy per seed, all seeds and each
generation's population simulated at once (vmapped); a candidate's fitness is the task loss of one
forward simulation, the rollout litl differentiates. A generation costs population + 1 simulations
(the candidates and the strategy's mean, whose loss is the generation's ``task_loss``).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from litl.config import RunContext, SettingsError
from litl.loop.algorithm import make_algorithm
from litl.optimizers.rounds import Cost, RoundsOptimizer, seed_keys
from litl.robots.robot import Robot
from litl.settings import Settings


@dataclass(frozen=True)
class EvolutionSettings(Settings):
    """An evolution strategy's keys (``optimizer.cmaes``, ``optimizer.sep_cmaes``,
    ``optimizer.openai_es``).

    Attributes:
      population: candidates per generation (>= 2); each costs one forward simulation.
      generations: generations to run (the budget: generations x (population + 1) simulations).
      sigma: the search distribution's (initial) standard deviation on the controller's weights
        and the design variables (Young's modulus in units of its range).
    """

    population: int = 16
    generations: int = 50
    sigma: float = 0.1

    def check(self) -> None:
        if isinstance(self.population, bool) or not isinstance(self.population, int) or self.population < 2:
            self._invalid("population", "must be an integer >= 2")
        self._positive_ints("generations")
        self._positive_numbers("sigma")


@dataclass(frozen=True)
class CMAESSettings(EvolutionSettings):
    """``optimizer.cmaes``: CMA-ES (`EvolutionSettings`' keys)."""


@dataclass(frozen=True)
class SepCMAESSettings(EvolutionSettings):
    """``optimizer.sep_cmaes``: separable CMA-ES (`EvolutionSettings`' keys)."""


@dataclass(frozen=True)
class OpenAIESSettings(EvolutionSettings):
    """``optimizer.openai_es``: `EvolutionSettings`' keys (the population even: its samples come
    in mirrored pairs) and

    Attributes:
      learning_rate: Adam's step size on the mean.
    """

    learning_rate: float = 0.03

    def check(self) -> None:
        super().check()
        if self.population % 2:
            self._invalid("population", "must be even for openai_es (its samples come in mirrored pairs)")
        self._positive_numbers("learning_rate")


def _strategy(kind: str, settings: EvolutionSettings, template):
    """The evosax strategy and its parameters: (separable) CMA-ES with its defaults but the initial
    step size; OpenAI-ES with mirrored sampling, a constant standard deviation and Adam on the mean."""
    import optax
    from evosax.algorithms import CMA_ES, Open_ES, Sep_CMA_ES

    if isinstance(settings, OpenAIESSettings):
        strategy = Open_ES(
            population_size=settings.population,
            solution=template,
            optimizer=optax.adam(settings.learning_rate),
            std_schedule=optax.constant_schedule(settings.sigma),
        )
        return strategy, strategy.default_params
    algorithm = {"cmaes": CMA_ES, "sep_cmaes": Sep_CMA_ES}[kind]
    strategy = algorithm(population_size=settings.population, solution=template)
    params = strategy.default_params
    return strategy, params.replace(std_init=jnp.asarray(settings.sigma, params.std_init.dtype))


@dataclass(frozen=True)
class DesignUnits:
    """The design φ in the units an evolution strategy searches, and back.

    The Young's modulus per region in units of its range (0: E_min, 1: E_max); a body space's
    occupancy as it is (in [0, 1]); its actuator logits over their starting sharpness (the
    robot's own channel starts at 1). Coming back, each is kept in its bounds as the loop's
    projection keeps it (the modulus and occupancy clipped, the logits free). What the search does
    not move (a growing projection's sharpness, a schedule) is kept as it started (`fixed`).
    """

    low: float
    high: float
    sharpness: float = 1.0
    body: bool = False  # φ is a body space's dict (`litl.designs.body.BodySpace`)

    @classmethod
    def of(cls, space, kind: str) -> DesignUnits:
        from litl.designs.body import BodySpace
        from litl.robots.design import DesignSpace

        low, high = space.bounds
        if isinstance(space, BodySpace):
            sharpness = space.placement.sharpness if space.placement is not None else 1.0
            return cls(float(low), float(high), float(sharpness), body=True)
        if isinstance(space, DesignSpace):
            return cls(float(low), float(high))
        raise SettingsError(
            f"optimizer={kind} searches litl's design spaces (modulus, actuators, geometry, all), "
            f"not {type(space).__name__}, whose units it does not know; use optimizer=litl",
            "design.kind",
        )

    def _modulus(self, youngs):
        return (youngs - self.low) / (self.high - self.low)

    def _youngs(self, unit):
        return self.low + jnp.clip(unit, 0.0, 1.0) * (self.high - self.low)

    def to_unit(self, phi):
        if not self.body:
            return self._modulus(phi)
        unit = {}
        if "youngs_modulus" in phi:
            unit["youngs_modulus"] = self._modulus(phi["youngs_modulus"])
        if "occupancy" in phi:
            unit["occupancy"] = phi["occupancy"]
        if "placement" in phi:
            unit["placement"] = phi["placement"] / self.sharpness
        return unit

    def fixed(self, phi):
        """What of φ the search keeps as it started ({} for the modulus)."""
        return {"projection": phi["projection"]} if self.body and "projection" in phi else {}

    def from_unit(self, unit, fixed):
        if not self.body:
            return self._youngs(unit)
        phi = dict(fixed)
        if "youngs_modulus" in unit:
            phi["youngs_modulus"] = self._youngs(unit["youngs_modulus"])
        if "occupancy" in unit:
            phi["occupancy"] = jnp.clip(unit["occupancy"], 0.0, 1.0)
        if "placement" in unit:
            phi["placement"] = unit["placement"] * self.sharpness
        return phi


class EvolutionStrategy:
    """`litl.optimizers.rounds.Method` for cmaes, sep_cmaes and openai_es: a round is one
    generation."""

    def __init__(self, robot: Robot, context: RunContext, kind: str, settings: EvolutionSettings):
        self.algorithm = algorithm = make_algorithm(robot, context.algorithm)
        if algorithm.observer.learned:
            raise SettingsError(
                f"optimizer={kind} optimizes the controller and design on fixed features, "
                f"and observer {context.algorithm.observer.kind!r} learns; use observer=kmeans or "
                f"observer=none",
                "observer.kind",
            )
        space = robot.design_space
        units = DesignUnits.of(space, kind)
        self.name = kind
        self.rounds = settings.generations
        self.seeds = context.seed_ids
        self._per_generation = settings.population + 1
        starts = [algorithm.init(seed) for seed in self.seeds]
        # The design in units that one step size suits, as it suits the controller's weights.
        normalized = [units.to_unit(s.design) for s in starts]
        fixed = [units.fixed(s.design) for s in starts]
        strategy, params = _strategy(kind, settings, (starts[0].controller, normalized[0]))
        stack = lambda trees: jax.tree.map(lambda *leaves: jnp.stack(leaves), *trees)  # seeds first
        self._observers = stack([(s.observer, f) for s, f in zip(starts, fixed, strict=True)])
        self._means = stack([(s.controller, u) for s, u in zip(starts, normalized, strict=True)])

        def fitness(solution, seed_inputs):
            observer, kept = seed_inputs
            controller, design = solution
            loss, _ = algorithm.simulate(controller, units.from_unit(design, kept), observer)
            return jnp.where(jnp.isfinite(loss), loss, jnp.inf)

        def generation(key, state, seed_inputs):
            ask_key, tell_key = jax.random.split(key)
            population, state = strategy.ask(ask_key, state, params)
            losses = jax.vmap(fitness, in_axes=(0, None))(population, seed_inputs)
            mean = strategy.get_mean(state)
            mean_loss = fitness(mean, seed_inputs)
            state, _ = strategy.tell(tell_key, population, losses, state, params)
            finite_mean = jnp.mean(jnp.where(jnp.isfinite(losses), losses, jnp.nan))
            # The mean's design as the loop reports its own (placement/..., geometry/...).
            figures = space.summary(units.from_unit(mean[1], seed_inputs[1]))
            return state, {
                "task_loss": mean_loss,
                "population_best": jnp.min(losses),
                "population_mean": finite_mean,
                **figures,
            }

        def advance(keys, states, observers):
            # Each generation's keys: every seed's key split, the first half kept.
            keys = jax.vmap(lambda k: jax.random.key_data(jax.random.split(jax.random.wrap_key_data(k))[0]))(
                keys
            )
            one = lambda key, state, observer: generation(jax.random.wrap_key_data(key), state, observer)
            states, figures = jax.vmap(one)(keys, states, observers)
            return (keys, states), figures

        self._advance = jax.jit(advance)  # traced once, not at every generation
        self._init = jax.vmap(lambda key, mean: strategy.init(jax.random.wrap_key_data(key), mean, params))

    def init(self):
        keys = seed_keys(self.seeds)
        return keys, self._init(keys, self._means)

    def advance(self, state, round_index: int):
        keys, states = state
        return self._advance(keys, states, self._observers)

    def cost(self, round_index: int) -> Cost:
        return Cost(self._per_generation * self.algorithm.steps, float(self._per_generation))


def evolution_strategy(kind: str):
    """The factory of `optimizer=<kind>` (cmaes, sep_cmaes or openai_es)."""

    def factory(robot: Robot, settings: EvolutionSettings, context: RunContext) -> RoundsOptimizer:
        method = EvolutionStrategy(robot, context, kind, settings)
        budget = f"{kind}, {settings.generations} generations of {settings.population}"
        return RoundsOptimizer(method, robot, context.record, budget)

    factory.__name__ = factory.__qualname__ = kind
    return factory
