"""Training callbacks: progress bar, collision rate, validation on fixed held-out seeds,
checkpoints (each every ``every`` environment steps, counted over all environments), and
the curriculum's stage."""

from __future__ import annotations

import json
import time
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from tqdm import tqdm

from lgmd_sim.core.fileio import write_files, write_text_atomic
from lgmd_sim.training.curriculum import Curriculum
from lgmd_sim.training.envs import VecEnvs

__all__ = ["Checkpoint", "EpisodeStats", "Progress", "StageCallback", "Validation",
           "run_episodes"]


class _Every(BaseCallback):
    """Calls ``_run()`` each time the step count passes a multiple of ``every``."""

    def __init__(self, every: int) -> None:
        super().__init__()
        self.every = every
        self._next = 0
        self.seconds = 0.0  # spent in _run: not training

    def _on_training_start(self) -> None:
        self._next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self._next = (self.num_timesteps // self.every + 1) * self.every
            self.timed_run()
        return True

    def run_now(self, model: Any) -> None:
        """Run outside ``learn()`` (after a DAgger round), at `model`'s step count."""
        self.init_callback(model)
        self.num_timesteps = model.num_timesteps
        self.timed_run()

    def timed_run(self) -> None:
        start = time.perf_counter()
        self._run()
        self.seconds += time.perf_counter() - start

    def _run(self) -> None:
        raise NotImplementedError


class Progress(BaseCallback):
    """A progress bar on stderr: steps, steps per second, the last validation scores.

    Args:
        total: the step count the run ends at.
        enabled: show it (None: only on a terminal).
    """

    def __init__(self, total: int, enabled: bool | None) -> None:
        super().__init__()
        self.total, self.enabled = total, enabled
        self.bar: tqdm | None = None

    def _on_training_start(self) -> None:
        self.bar = tqdm(total=self.total, initial=self.num_timesteps, desc="train",
                        unit="step", unit_scale=True, dynamic_ncols=True, leave=False,
                        disable=None if self.enabled is None else not self.enabled)

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return True

    def show(self, scores: dict[str, float]) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(", ".join(f"{k} {v:.2f}" for k, v in scores.items()))

    def _on_training_end(self) -> None:
        self.bar.close()


class EpisodeStats(BaseCallback):
    """Logs ``rollout/collision_rate``: the share of the last 100 training episodes that
    ended in a collision (stable-baselines3 logs their return and success rate)."""

    def __init__(self) -> None:
        super().__init__()
        self.collided: deque[bool] = deque(maxlen=100)

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done:
                self.collided.append(info.get("first_collision_frame", -1) >= 0)
        if self.collided:
            self.logger.record("rollout/collision_rate", float(np.mean(self.collided)))
        return True


def _task_rewards(rewards: np.ndarray, infos: Sequence[dict[str, Any]]) -> np.ndarray:
    """Each environment's step reward without the shaping terms (``info["task_reward"]``),
    so that validation scores the task whatever the shaping; the reward where the info
    has none (an environment without shaping)."""
    return np.array([info.get("task_reward", reward)
                     for reward, info in zip(rewards, infos, strict=True)], float)


def run_episodes(model: Any, envs: VecEnvs, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """One episode per seed, the policy deterministic: return (of the unshaped task reward),
    success, collision and distance travelled of each. `seeds` must be consecutive; the
    environments play ``num_envs`` of them at a time, and the policy acts on each
    environment's observation alone, through the same arithmetic as the controller of
    ``lgmd-sim bench closed-loop --policies`` (`lgmd_sim.policies.forward`, else
    ``predict``): a batch, or another
    order of the sums, rounds differently (about 1e-7), which a closed loop can grow into
    another episode."""
    from lgmd_sim.policies import forward

    venv, n = envs.venv, envs.venv.num_envs
    act = forward.build(model.policy)  # the weights as they are at this validation

    def action(obs: dict[str, np.ndarray], i: int) -> np.ndarray:
        if act is not None:
            return act({k: v[i] for k, v in obs.items()})[None]
        return model.predict({k: v[i:i + 1] for k, v in obs.items()}, deterministic=True)[0]

    results = []
    for start in range(0, len(seeds), n):
        batch = seeds[start:start + n]
        venv.seed(batch[0])  # environment i resets with seed batch[0] + i
        obs = venv.reset()
        pos = np.array([info["carrier_pos"][:2] for info in envs.base.reset_infos])
        playing = np.arange(n) < len(batch)
        ret, dist = np.zeros(n), np.zeros(n)
        while playing.any():
            actions = np.concatenate([action(obs, i) for i in range(n)])
            obs, rewards, dones, infos = venv.step(actions)
            now = np.array([info["carrier_pos"][:2] for info in infos])
            ret += np.where(playing, _task_rewards(rewards, infos), 0.0)
            dist += np.where(playing, np.linalg.norm(now - pos, axis=1), 0.0)
            pos = now
            for i in np.flatnonzero(playing & dones):
                playing[i] = False
                results.append({"seed": batch[i], "return": float(ret[i]),
                                "success": bool(infos[i]["is_success"]),
                                "collided": infos[i]["first_collision_frame"] >= 0,
                                "distance_m": float(dist[i])})
    return sorted(results, key=lambda r: r["seed"])


class Validation(_Every):
    """Every `every` steps and at the end, the policy on fixed held-out episode seeds:
    logs ``eval/mean_reward`` (the task's reward, without the shaping terms),
    ``eval/success_rate``, ``eval/collision_rate`` and ``eval/mean_distance_m``, and hands
    the scores to `on_scores` (which may save the best policy).

    Args:
        envs: the validation environments (a VecEnv whose VecNormalize, if any, does not
            train and gets the training statistics before each validation).
        seeds: the episode seeds, consecutive.
        every: steps between validations.
        sync: copies the training normalisation statistics into `envs` (or None).
        on_scores: called with the step count and the scores.
    """

    def __init__(self, envs: VecEnvs, seeds: Sequence[int], every: int,
                 sync: Callable[[], None] | None,
                 on_scores: Callable[[int, dict[str, float]], None]) -> None:
        super().__init__(every)
        self.envs, self.seeds, self.sync, self.on_scores = envs, list(seeds), sync, on_scores
        self.last_step = -1
        self.scores: dict[str, float] = {}  # the last validation's

    def _run(self) -> None:
        if self.sync:
            self.sync()
        episodes = run_episodes(self.model, self.envs, self.seeds)
        scores = {"mean_reward": float(np.mean([e["return"] for e in episodes])),
                  "success_rate": float(np.mean([e["success"] for e in episodes])),
                  "collision_rate": float(np.mean([e["collided"] for e in episodes])),
                  "mean_distance_m": float(np.mean([e["distance_m"] for e in episodes]))}
        for key, value in scores.items():
            self.logger.record(f"eval/{key}", value)
        self.logger.record("time/total_timesteps", self.num_timesteps)
        self.logger.dump(self.num_timesteps)
        self.last_step, self.scores = self.num_timesteps, scores
        self.on_scores(self.num_timesteps, scores)

    def _on_training_end(self) -> None:
        if self.last_step != self.num_timesteps:  # the final policy's scores
            self.timed_run()


class Checkpoint(_Every):
    """Every `every` steps, and at the end, what resuming needs in ``folder``: the model
    (``model.zip``), the VecNormalize statistics (``vecnormalize.pkl``), an off-policy
    algorithm's replay buffer (``replay_buffer.pkl``) and ``state.json`` (the step
    count, and what `state` returns: the curriculum's stage), written last, so that a
    checkpoint is complete once state.json names it.
    """

    def __init__(self, folder: Path, every: int,
                 state: Callable[[], dict[str, Any]] | None = None) -> None:
        super().__init__(every)
        self.folder, self.state = folder, state

    def _run(self) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        # the temporary files keep the suffix, so SB3 writes them as they are named
        writers = {self.folder / "model.zip": self.model.save}
        if (normalized := self.model.get_vec_normalize_env()) is not None:
            writers[self.folder / "vecnormalize.pkl"] = normalized.save
        if hasattr(self.model, "replay_buffer"):
            writers[self.folder / "replay_buffer.pkl"] = self.model.save_replay_buffer
        write_files(writers)
        write_text_atomic(self.folder / "state.json", json.dumps(
            {"num_timesteps": self.num_timesteps, **(self.state() if self.state else {})}))

    def _on_training_end(self) -> None:
        self.timed_run()


class StageCallback(BaseCallback):
    """Counts the current stage's training successes and stops ``learn()`` once the last
    ``window`` episodes reach its ``advance_at`` (``ready``); the run then calls `advance`
    and builds the environments of the next stage. On the task itself (past the last
    stage) it only counts.

    Args:
        curriculum: the stages.
        stage: the stage training starts at (a resumed run's).
    """

    def __init__(self, curriculum: Curriculum, stage: int) -> None:
        super().__init__()
        self.curriculum, self.stage = curriculum, stage
        self.successes: deque[bool] = deque(maxlen=curriculum.window)
        self.episodes = 0
        self.ready = False  # learn() stopped: the stage is passed

    @property
    def on_task(self) -> bool:
        return self.stage >= len(self.curriculum.stages)

    def success_rate(self) -> float | None:
        return sum(self.successes) / len(self.successes) if self.successes else None

    def advance(self) -> None:
        self.stage += 1
        self.successes.clear()
        self.episodes, self.ready = 0, False

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done:
                self.successes.append(bool(info.get("is_success", False)))
                self.episodes += 1
        if self.on_task or len(self.successes) < self.curriculum.window:
            return True
        self.ready = self.success_rate() >= self.curriculum.stages[self.stage].advance_at
        return not self.ready
