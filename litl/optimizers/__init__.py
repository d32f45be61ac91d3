"""Optimization methods: what changes the controller and the design (``optimizer=<name>``), one
module each, all behind one interface and one registry (`litl.optimizers.interface`):

* ``litl`` (`loop`, the default): litl's loop, Algorithm 1 (its settings: the config's `loop`);
* ``cmaes``, ``sep_cmaes``, ``openai_es`` (`evolution`, evosax): evolution strategies on the
  controller network θ and the design φ that litl's loop optimizes, from forward simulations
  only; the observer is fixed (kmeans, fitted at the start, or none; the presets pick kmeans);
* ``ppo`` (`ppo`, rejax): PPO on `litl.envs`, controlling only (the design stays at its start);
  it observes the particle summary (the preset sets observer=none).

    python -m litl optimizer=sep_cmaes seeds=10        # separable CMA-ES on the biped
    python -m litl optimizer=ppo optimizer.ppo.timesteps=131072

Each writes a litl run directory (`litl.loop.run_directory`): run.json (settings, with the
method's section), metrics.jsonl (the methods that run in rounds, `litl.optimizers.rounds`: one
record per round and seed, with ``task_loss``, ``simulations`` and ``simulated_steps`` so far, a
forward simulation step counting 1, ``wall_s`` and the method's own figures), checkpoints/ (a
killed or paused run resumes from its last one, with the same records) and final.json, so
`python -m litl.report` draws it beside litl's runs (labelled by the method's name). A method of
one's own registers like an observer (`register`, ``optimizer.module=<module>``; the loop guide
shows one). Before 2026-12-02 these were ``baseline=<name>`` with one shared section; the old
spellings still work, with a message.
"""

from litl.optimizers.evolution import CMAESSettings, OpenAIESSettings, SepCMAESSettings, evolution_strategy
from litl.optimizers.interface import OPTIMIZERS, Optimizer, OptimizerContext, make, names, register
from litl.optimizers.loop import litl_loop
from litl.optimizers.ppo import PPOSettings, ppo

if "litl" not in OPTIMIZERS.names():  # a module reloaded (importlib.reload) registers once
    register("litl", litl_loop)
    register("cmaes", evolution_strategy("cmaes"), CMAESSettings)
    register("sep_cmaes", evolution_strategy("sep_cmaes"), SepCMAESSettings)
    register("openai_es", evolution_strategy("openai_es"), OpenAIESSettings)
    register("ppo", ppo, PPOSettings)

__all__ = ["Optimizer", "OptimizerContext", "make", "names", "register"]
