"""What `lgmd-sim train` trains: `TrainConfig`, every option of a run checked when it is made
(a bad value is a one-line ValueError naming it, before anything starts), and the seeds a
run validates on (`VALIDATION_SEED`). Its fields are the keys of ``lgmd-sim train --config
FILE.toml`` (`lgmd_sim.core.configfile` reads, writes and lists them).
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.params import because, checked, count, int_at_least, one_of, seed, text, tuple_of
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.folder import ALGOS, OBS
from lgmd_sim.training.dagger import FIT_EPOCHS, STUDENT_ACTIONS

if TYPE_CHECKING:
    from lgmd_sim.training.curriculum import Curriculum

__all__ = ["KEYS_LISTED", "VALIDATION_SEED", "TrainConfig"]

#: Where a user reads the keys of a --config file, each with its default and meaning.
KEYS_LISTED = "TrainConfig's fields, listed in docs/guides/training.md"
#: The first validation seed; training seeds stay below it, test seeds start at 1000.
VALIDATION_SEED = 900


@dataclass(frozen=True)
class TrainConfig:
    """What a training run trains, checked when it is made (a bad value raises a
    one-line ValueError naming it).

    Every field is a key of ``lgmd-sim train --config FILE.toml`` (some are options of the
    command too), declared with its default and meaning by `lgmd_sim.core.configfile.setting`
    (docs/guides/training.md lists them).
    """

    algo: str = setting("ppo", 'the algorithm, a key of `lgmd_sim.policies.folder.ALGOS`: "ppo" '
                        'or "sac"')
    env: str = setting("lgmd_sim/RoughTerrainObstacles-v0",
                       "the Gymnasium id of the environment (`lgmd-sim envs` lists them)")
    obs: str = setting("features", 'what the policy sees: "features" (an LGMD model\'s '
                       "potential history, alarm and S-layer grid, with the proprioception and "
                       'goal; an MLP), "pixels" (small stacked grey frames with the '
                       'proprioception and goal; a CNN) or "privileged" (the ground truth the '
                       "Oracle reads: the threat's distance, bearing, time to collision and "
                       "closing speed, with the proprioception and goal; an MLP, the upper bound "
                       "for the others)")
    model: str | None = setting("feedback", 'the LGMD model of "features", MODEL or MODEL/PRESET '
                                "(with front ends); none for the other observations")
    preset: str | None = setting(None, "the model's preset (unset: the model's default)")
    grid: tuple[int, int] = setting(
        PolicyConfig.grid, '[rows, columns] of the S-layer grid of "features", each cell '
        "holding its share of the layer's activity ([1, 3]: left, centre, right; "
        "`lgmd_sim.envs.wrappers.LGMDFeatures`; a plug-in without an S layer: its last "
        "layer's, and one without layers is refused: `lgmd_sim.models.layers`)")
    grid_history: int = setting(
        PolicyConfig.grid_history, 'how many of the last grids "features" observes, oldest '
        "first (1: the present frame's; more show where the activity grows)")
    memory: int = setting(
        PolicyConfig.memory, '"features" also observes, per column of the grid, the '
        "potential's excitation seen there lately, fading over this many frames (30: a "
        "second), for what has left the frame; 0: none "
        "(`lgmd_sim.envs.wrappers.LGMDFeatures`)")
    resolution: str | tuple[int, int] = setting(
        "rl", 'the frame size the environment renders: "rl" (120x160, as the benchmark), '
        '"paper", "small" or "HxW"')
    jitter: float = setting(1.0, "the jitter level of the training episodes")
    steps: int = setting(300_000, "environment steps in all, over every environment and "
                         "session (with --resume, the new total)")
    envs: int = setting(2, "environments stepped in parallel, one worker process each")
    seed: int = setting(0, "seed of the model and of the first training environment "
                        "(training seeds stay below 900, `VALIDATION_SEED`)")
    eval_every: int = setting(25_000, "validate every this many environment steps (and at the "
                              "end)")
    eval_seeds: int = setting(10, "validation episodes, on the held-out seeds 900 "
                              "(`VALIDATION_SEED`) to 900 + eval_seeds - 1")
    checkpoint_every: int = setting(25_000, "write a checkpoint every this many environment "
                                    "steps (and at the end)")
    hp: tuple[str, ...] = setting(
        (), 'hyperparameter overrides of the algorithm, each "KEY=VALUE" '
        '(`lgmd_sim.training.algos`), e.g. ["n_steps=512", "learning_rate=1e-4"]; a resumed '
        "run adds them to its own (a later one wins), not policy_kwargs (the checkpoint's "
        'network has its shape), e.g. ["target_kl=0.02"] for gentler fine-tuning')
    reward: tuple[str, ...] = setting(
        (), 'reward parameters of the training environments, each "KEY=VALUE" with KEY one '
        "of progress_reward, collision_penalty, effort_penalty, goal_bonus, time_penalty or "
        "proximity_penalty (`lgmd-sim envs NAME` lists them; the shaping ones are off by "
        "default; `lgmd_sim.training.envs.parse_reward`), e.g. [\"goal_bonus=5\"]; "
        "validation and `lgmd-sim bench closed-loop --policies` keep the environment's own "
        "reward")
    curriculum: str | None = setting(
        None, "go through easier versions of the task first, each stage passed at a success "
        "rate of its training episodes: a built-in curriculum (\"obstacles\": no obstacle "
        "and the goal 4 m away, then 2 obstacles at 6 m, 4 at 8 m, then the task) or a TOML "
        "file of stages (`lgmd_sim.training.curriculum`); validation always runs on the "
        "task; unset: the task from the start")
    teacher: str | None = setting(
        None, "learn from a teacher first, by DAgger (`lgmd_sim.training.dagger`; PPO only): "
        "\"oracle\" (the Oracle controller), \"steer\" (the Oracle's inputs without its "
        "memory, `lgmd_sim.controllers.steer`: what a policy can copy), \"reactive\" "
        "(ReactiveAvoid's manoeuvre on the policy's own LGMD alarm; obs \"features\") or a "
        "privileged policy (a folder trained with obs \"privileged\", or a shipped name) "
        "labels the states the policy visits, the policy is fitted to the labels, then RL "
        "fine-tunes it; unset: RL from the start")
    imitation_steps: int = setting(100_000, "environment steps of the DAgger rounds, part of "
                                   "steps")
    dagger_rounds: int = setting(10, "DAgger rounds, of imitation_steps / dagger_rounds steps "
                                 "each: the teacher drives round 0, then less and less, none "
                                 "from half the rounds on")
    dagger_epochs: int = setting(FIT_EPOCHS, "cloning's epochs over all the labels kept, after "
                                 "each DAgger round")
    dagger_student: str = setting(
        "sample", "how the student acts on the steps it drives in the DAgger rounds: "
        "\"sample\" its Gaussian or take its \"mean\", the action validation and `lgmd-sim "
        "bench closed-loop --policies` execute (`lgmd_sim.training.dagger.STUDENT_ACTIONS`)")
    value_warmup: int = setting(
        0, "after DAgger, this many environment steps of PPO in which only the value "
        "function learns (`lgmd_sim.training.dagger.critic_only`), so that fine-tuning "
        "starts from advantages that mean something; part of steps, 0: none. Given when "
        "resuming a run past its DAgger rounds that had none, the warm-up starts there; it "
        "runs once")

    def __post_init__(self) -> None:
        # in this order: the message names the first bad option
        self._check_policy()
        self._check_budget()
        self._check_teacher()

    def _check_policy(self) -> None:
        """The options' types, and the policy: its algorithm, environment and observation."""
        import gymnasium as gym

        from lgmd_sim import models
        from lgmd_sim.models.layers import needed_layer

        # options of the wrong type (a hand-edited run.json being resumed brings them too)
        checked("env", self.env, text)
        for key in ("hp", "reward"):
            checked(key, getattr(self, key), because(tuple_of(text), "KEY=VALUE strings"))
        checked("algo", self.algo, one_of(*ALGOS))
        checked("obs", self.obs, one_of(*OBS))
        try:
            gym.spec(self.env)
        except gym.error.Error:
            raise ValueError(f"unknown environment id {self.env!r} (lgmd-sim envs lists "
                             "them)") from None
        if self.obs == "features":
            model, preset = models.parse_spec(
                str(self.model) if self.preset is None else f"{self.model}/{self.preset}")
            # the grid is every features policy's: a model without layers is refused
            # before the run folder, not with a KeyError at the first frame
            needed_layer(model, "--obs features observes a grid of the activity of",
                         "give it a layer (layer_names, filled by step_batch), or train "
                         "on --obs pixels or privileged, which read no model")
        else:
            model = preset = None
        grid = checked("grid", self.grid, because(tuple_of(count, 2), "[rows, columns]"))
        object.__setattr__(self, "grid", tuple(grid))
        checked("grid_history", self.grid_history, count)
        checked("memory", self.memory, int_at_least(0))
        for key in ("grid", "grid_history", "memory"):
            if self.obs != "features" and getattr(self, key) != getattr(PolicyConfig, key):
                raise ValueError(f"{key} is of obs features, not {self.obs}")
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "preset", preset)
        object.__setattr__(self, "resolution", options.resolution(self.resolution))

    def _check_budget(self) -> None:
        """Steps, environments, validation, checkpoints, seeds, hyperparameters, reward
        shaping and curriculum."""
        from lgmd_sim.training import algos
        from lgmd_sim.training.envs import parse_reward

        for key in ("steps", "envs", "eval_every", "checkpoint_every", "eval_seeds"):
            checked(key, getattr(self, key), count)
        if self.eval_seeds > 1000 - VALIDATION_SEED:
            raise ValueError(f"eval_seeds must be at most {1000 - VALIDATION_SEED} "
                             f"(validation seeds are {VALIDATION_SEED} to 999), got "
                             f"{self.eval_seeds}")
        checked("seed", self.seed, seed)
        checked("jitter", [self.jitter], options.jitter_list)
        object.__setattr__(self, "hp", tuple(self.hp))
        algos.parse_overrides(self.hp, self.algo)
        object.__setattr__(self, "reward", tuple(self.reward))
        parse_reward(self.reward)
        self.stages  # noqa: B018  (loads the curriculum once: a bad one is one line now)

    def _check_teacher(self) -> None:
        """DAgger's options, and the teacher (loaded: a bad one is one line now)."""
        for key in ("imitation_steps", "dagger_rounds", "dagger_epochs"):
            checked(key, getattr(self, key), count)
        checked("dagger_student", self.dagger_student, one_of(*STUDENT_ACTIONS))
        checked("value_warmup", self.value_warmup, int_at_least(0))
        if self.value_warmup and self.teacher is None:
            raise ValueError("value_warmup warms the value function up after DAgger: it "
                             "needs a teacher")
        if self.teacher is not None:
            from lgmd_sim.training.dagger import Teacher

            if self.algo != "ppo":
                raise ValueError(f"teacher needs algo ppo (its policy is fitted to the "
                                 f"teacher's actions), not {self.algo}")
            if self.imitation_steps + self.value_warmup >= self.steps:
                warmup = f" and value_warmup {self.value_warmup}" if self.value_warmup else ""
                raise ValueError(f"imitation_steps {self.imitation_steps}{warmup} must be "
                                 f"fewer than --steps {self.steps} (RL fine-tuning takes the "
                                 "rest)")
            if self.imitation_steps < self.dagger_rounds * self.envs:
                raise ValueError(f"imitation_steps {self.imitation_steps} must be at least "
                                 f"dagger_rounds x --envs ({self.dagger_rounds * self.envs}): "
                                 "a step per environment and round")
            if not isinstance(self.teacher, str):
                raise ValueError(f"teacher must be oracle, steer, reactive or a policy, got "
                                 f"{self.teacher!r}")
            try:
                Teacher(self.teacher, 1, self.policy())  # loads: a bad teacher is one line now
            except ValueError as exc:
                # a policy's own refusals name its folder, not the key that gave it
                text = str(exc)
                raise ValueError(text if text.startswith("teacher")
                                 else f"teacher {self.teacher}: {text}") from None

    def policy(self) -> PolicyConfig:
        """The configuration of the policy it trains."""
        return PolicyConfig(self.algo, self.obs, self.env, self.resolution,
                            float(self.jitter), self.model, self.preset, grid=self.grid,
                            grid_history=self.grid_history, memory=self.memory)

    def as_json(self) -> dict[str, Any]:
        """The configuration as the run folder records it."""
        return json.loads(json.dumps(dataclasses.asdict(self)))

    @functools.cached_property
    def stages(self) -> Curriculum | None:
        """The curriculum's stages (read once: a file changed during the run changes
        nothing), or None without one."""
        from lgmd_sim.training.curriculum import load

        return None if self.curriculum is None else load(self.curriculum, self.env)

    def stage_overrides(self, stage: int) -> dict[str, Any]:
        """The environment parameters of curriculum stage `stage` (none past the last)."""
        curriculum = self.stages
        return (dict(curriculum.stages[stage].overrides)
                if curriculum and stage < len(curriculum.stages) else {})

    def overrides(self, stage: int) -> dict[str, Any]:
        """The training environments' parameters at curriculum stage `stage`, the reward
        shaping included."""
        from lgmd_sim.training.envs import parse_reward

        return {**parse_reward(self.reward), **self.stage_overrides(stage)}
