"""What `lgmd-sim train` trains: `TrainConfig`, every option of a run checked when it is made
(a bad value is a one-line ValueError naming it, before anything starts), and the seeds
a run validates on (`VALIDATION_SEED`).
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from lgmd_sim.controllers import options
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.folder import ALGOS, OBS
from lgmd_sim.training.dagger import FIT_EPOCHS, STUDENT_ACTIONS

if TYPE_CHECKING:
    from lgmd_sim.training.curriculum import Curriculum

__all__ = ["VALIDATION_SEED", "TrainConfig"]

#: The first validation seed; training seeds stay below it, test seeds start at 1000.
VALIDATION_SEED = 900


@dataclass(frozen=True)
class TrainConfig:
    """What a training run trains, checked when it is made (a bad value raises a
    one-line ValueError naming it).

    Attributes:
        algo: a key of `lgmd_sim.policies.folder.ALGOS` ("ppo", "sac").
        env: the Gymnasium id of the environment.
        obs: "features" (an LGMD model's signals with the proprioception and goal),
            "pixels" (small stacked grey frames) or "privileged" (the threat's ground
            truth that the Oracle reads, with the proprioception and goal).
        model, preset: the LGMD model of "features", MODEL or MODEL/PRESET (with front
            ends), and its preset (None: the model's default); both None otherwise.
        grid: (rows, columns) of the S-layer grid of "features"
            (`lgmd_sim.envs.wrappers.LGMDFeatures`; a plug-in without an S layer: its
            last layer's, and one without layers is refused: `lgmd_sim.models.layers`).
        grid_history: how many of the last grids "features" observes (1: the present).
        memory: frames the per-column memory of the excitation of "features" lasts, 0
            for none (`lgmd_sim.envs.wrappers.LGMDFeatures`).
        resolution: the frame size the environment renders.
        jitter: the jitter level of the training episodes.
        steps: environment steps in all, over every environment and session.
        envs: environments stepped in parallel (worker processes).
        seed: seed of the model and of the first training environment.
        eval_every, eval_seeds: validate every N steps on this many held-out seeds (from
            `VALIDATION_SEED`).
        checkpoint_every: write a checkpoint every N steps.
        hp: hyperparameter overrides, each "KEY=VALUE" (`lgmd_sim.training.algos`); a
            resumed run may add some (a later one wins), not ``policy_kwargs`` (the
            checkpoint's network has its shape).
        reward: reward parameters of the training environments, each "KEY=VALUE"
            (`lgmd_sim.training.envs.parse_reward`); validation keeps the environment's.
        curriculum: a curriculum (`lgmd_sim.training.curriculum`: a built-in name or a
            TOML file) the training environments go through before the task itself;
            None: the task from the start.
        teacher: "oracle", "steer" (the Oracle's inputs without its memory,
            `lgmd_sim.controllers.steer`), "reactive" (ReactiveAvoid's rule on the
            policy's own LGMD features) or a privileged policy (a folder or a shipped
            name) the policy first learns from by DAgger (`lgmd_sim.training.dagger`),
            before RL; None: RL from the start. PPO only.
        imitation_steps: environment steps of the DAgger rounds (part of `steps`).
        dagger_rounds: DAgger rounds, each ``imitation_steps / dagger_rounds`` steps.
        dagger_epochs: cloning's epochs over the labels kept after each round.
        dagger_student: how the student acts on the steps it drives in the rounds,
            "sample" or "mean" (`lgmd_sim.training.dagger.STUDENT_ACTIONS`).
        value_warmup: environment steps of PPO after the DAgger rounds in which only the
            value function learns (`lgmd_sim.training.dagger.critic_only`), part of
            `steps`; 0: none. Given when resuming a run past its DAgger rounds that had
            none, the warm-up starts there; it runs once.
    """

    algo: str = "ppo"
    env: str = "lgmd_sim/RoughTerrainObstacles-v0"
    obs: str = "features"
    model: str | None = "feedback"
    preset: str | None = None
    grid: tuple[int, int] = PolicyConfig.grid
    grid_history: int = PolicyConfig.grid_history
    memory: int = PolicyConfig.memory
    resolution: str | tuple[int, int] = "rl"
    jitter: float = 1.0
    steps: int = 300_000
    envs: int = 2
    seed: int = 0
    eval_every: int = 25_000
    eval_seeds: int = 10
    checkpoint_every: int = 25_000
    hp: tuple[str, ...] = ()
    reward: tuple[str, ...] = ()
    curriculum: str | None = None
    teacher: str | None = None
    imitation_steps: int = 100_000
    dagger_rounds: int = 10
    dagger_epochs: int = FIT_EPOCHS
    dagger_student: str = "sample"
    value_warmup: int = 0

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
        for key in ("algo", "obs", "env"):
            if not isinstance(getattr(self, key), str):
                raise ValueError(f"--{key} must be a string, got {getattr(self, key)!r}")
        for key in ("hp", "reward"):
            items = getattr(self, key)
            if not (isinstance(items, list | tuple) and all(isinstance(v, str) for v in items)):
                raise ValueError(f"--{key} must be a list of KEY=VALUE strings, got {items!r}")
        if self.algo not in ALGOS:
            raise ValueError(f"unknown algorithm {self.algo!r}; available: {', '.join(ALGOS)}")
        if self.obs not in OBS:
            raise ValueError(f"unknown observation {self.obs!r}; available: {', '.join(OBS)}")
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
        grid = tuple(self.grid) if isinstance(self.grid, list | tuple) else ()
        if not (len(grid) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                       and v >= 1 for v in grid)):
            raise ValueError(f"--grid must be rows x columns of positive integers, got "
                             f"{self.grid!r}")
        if self.obs != "features" and grid != PolicyConfig.grid:
            raise ValueError(f"--grid is the S-layer grid of --obs features, not {self.obs}")
        object.__setattr__(self, "grid", grid)
        for key, least, what in (("grid_history", 1, "a positive integer"),
                                 ("memory", 0, "a non-negative integer (frames)")):
            value, option = getattr(self, key), f"--{key.replace('_', '-')}"
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= least):
                raise ValueError(f"{option} must be {what}, got {value!r}")
            if self.obs != "features" and value != getattr(PolicyConfig, key):
                raise ValueError(f"{option} is of --obs features, not {self.obs}")
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "preset", preset)
        object.__setattr__(self, "resolution", options.resolution(self.resolution))

    def _check_budget(self) -> None:
        """Steps, environments, validation, checkpoints, seeds, hyperparameters, reward
        shaping and curriculum."""
        from lgmd_sim.training import algos
        from lgmd_sim.training.envs import parse_reward

        for key in ("steps", "envs", "eval_every", "checkpoint_every", "eval_seeds"):
            options.check_positive(getattr(self, key), f"--{key.replace('_', '-')}",
                                   integer=True)
        if self.eval_seeds > 1000 - VALIDATION_SEED:
            raise ValueError(f"--eval-seeds must be at most {1000 - VALIDATION_SEED} "
                             f"(validation seeds are {VALIDATION_SEED} to 999), got "
                             f"{self.eval_seeds}")
        options.check_seed(self.seed, "--seed")
        options.check_jitter([self.jitter])
        object.__setattr__(self, "hp", tuple(self.hp))
        algos.parse_overrides(self.hp, self.algo)
        object.__setattr__(self, "reward", tuple(self.reward))
        parse_reward(self.reward)
        self.stages  # noqa: B018  (loads the curriculum once: a bad one is one line now)

    def _check_teacher(self) -> None:
        """DAgger's options, and the teacher (loaded: a bad one is one line now)."""
        for key in ("imitation_steps", "dagger_rounds", "dagger_epochs"):
            options.check_positive(getattr(self, key), f"--{key.replace('_', '-')}",
                                   integer=True)
        if self.dagger_student not in STUDENT_ACTIONS:
            raise ValueError(f"--dagger-student must be one of {', '.join(STUDENT_ACTIONS)}, "
                             f"got {self.dagger_student!r}")
        if not (isinstance(self.value_warmup, int) and not isinstance(self.value_warmup, bool)
                and self.value_warmup >= 0):
            raise ValueError(f"--value-warmup must be a non-negative integer, got "
                             f"{self.value_warmup!r}")
        if self.value_warmup and self.teacher is None:
            raise ValueError("--value-warmup warms the value function up after DAgger: it "
                             "needs --teacher")
        if self.teacher is not None:
            from lgmd_sim.training.dagger import Teacher

            if self.algo != "ppo":
                raise ValueError(f"--teacher needs --algo ppo (its policy is fitted to the "
                                 f"teacher's actions), not {self.algo}")
            if self.imitation_steps + self.value_warmup >= self.steps:
                warmup = f" and --value-warmup {self.value_warmup}" if self.value_warmup else ""
                raise ValueError(f"--imitation-steps {self.imitation_steps}{warmup} must be "
                                 f"fewer than --steps {self.steps} (RL fine-tuning takes the "
                                 "rest)")
            if self.imitation_steps < self.dagger_rounds * self.envs:
                raise ValueError(f"--imitation-steps {self.imitation_steps} must be at least "
                                 f"--dagger-rounds x --envs ({self.dagger_rounds * self.envs}): "
                                 "a step per environment and round")
            Teacher(self.teacher, 1, self.policy())  # loads: a bad teacher is one line now

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
