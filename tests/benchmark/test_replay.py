"""Episodes that replay on any processor (issue 50): the numeric mode pinned in every
process (`lgmd_sim.core.numerics`), episodes' fingerprints (`lgmd_sim.benchmark.fingerprint`),
golden fingerprints of a few short episodes, and `lgmd-sim verify` on a tampered result.

The golden fingerprints were recorded in the replay mode on an AMD EPYC (Zen 4, AVX-512);
the same test on another x86-64 processor with AVX2 says whether the promise holds there."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim.benchmark.episode import Cell, episode
from lgmd_sim.benchmark.fingerprint import EVERY, Fingerprint, first_difference
from lgmd_sim.core import numerics

ROOT = Path(__file__).resolve().parents[2]
X86 = bool(numerics.pinned_environment())

#: One episode each, RoughTerrainObstacles at jitter 1, seed 20000, 64 x 64: what it went
#: through, to the bit (the potential of the detector that drives it included).
GOLDEN = {
    "straight": (Cell("RoughTerrainObstacles", 1.0, "straight"),
                 "e5c77bf5d0abd1a5b89a1f5a395fbe601f9e58962ca331a4de87f455d4cd2189"),
    "oracle": (Cell("RoughTerrainObstacles", 1.0, "oracle"),
               "b8f89d5a6b0bbe27114abaf77a115da51d127350ea2db525b6565198d2f0baf7"),
    "loom-steer": (Cell("RoughTerrainObstacles", 1.0, "loom-steer", "lgmd1", "robot-image"),
                   "6d5d8dbd2fe24a72629560c2d9a84e5b09643a5073b9d5ec0d37772ec689a4d0"),
    # a plug-in in NumPy (examples/eta_lgmd.py), driving the reference controller
    "plug-in": (Cell("RoughTerrainObstacles", 1.0, "reactive", "eta_lgmd:EtaLGMD", "gabbiani"),
                "d71a0e8326973e52da9e5c3b81b7935191669c2e31e296b8d695cee0a5eb4336"),
}


#: The shipped policy (its actions computed by lgmd_sim.policies.forward) on the same episode,
#: at the frames it was trained on: 120 x 160 ("rl"; it refuses 64 x 64).
POLICY_GOLDEN = "46d1d18dc2e2532614151617d9ab6c829859c3b43e19becb8d0153bbaceac04c"


def _fingerprint(cell: Cell) -> dict:
    return episode(cell, 20000, resolution="small", cruise=0.6, horizon=2.0)["fingerprint"]


def test_the_suite_computes_in_the_replay_mode():
    assert numerics.mode() == "replay"


@pytest.mark.skipif(not X86, reason="the golden fingerprints are x86-64's")
@pytest.mark.parametrize("name", GOLDEN)
def test_a_short_episode_gives_its_golden_fingerprint(name, monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "examples"))
    cell, golden = GOLDEN[name]
    assert _fingerprint(cell)["sha256"] == golden, (
        f"{name}: this processor computes another episode than the one recorded (AMD EPYC, "
        "replay mode)")


@pytest.mark.skipif(not X86, reason="the golden fingerprints are x86-64's")
def test_the_shipped_policy_s_short_episode_gives_its_golden_fingerprint():
    pytest.importorskip("stable_baselines3")
    record = episode(Cell("RoughTerrainObstacles", 1.0, "policy"), 20000, resolution="rl",
                     cruise=0.6, horizon=2.0)
    assert record["fingerprint"]["sha256"] == POLICY_GOLDEN, (
        "the shipped policy: this processor computes another episode than the one recorded "
        "(AMD EPYC, replay mode)")


#: The demo's avoiding episode (`lgmd_sim.apps.defaults`): its potentials' SHA-256.
DEMO_POTENTIALS = "5701de489afe275f91633024261fdfb79de0e512563198b07ace908617524a1f"


@pytest.mark.skipif(not X86, reason="the golden fingerprints are x86-64's")
def test_the_demo_s_avoiding_episode_reaches_the_goal_as_its_defaults_say():
    import hashlib

    from lgmd_sim.apps import avoid
    from lgmd_sim.apps.defaults import AVOID_SEED, AVOIDER

    ep = avoid.drive(AVOID_SEED, 1.0, *avoid.parse_avoider(AVOIDER))
    alarm = np.asarray(ep.alarm)
    onsets = int((alarm & ~np.concatenate([[False], alarm[:-1]])).sum())
    # defaults.py: it reaches the goal at frame 609 with five alarms
    assert (ep.goal_reached, len(ep.frames) - 1, onsets) == (True, 609, 5)
    digest = hashlib.sha256(np.nan_to_num(ep.potential).tobytes()).hexdigest()
    assert digest == DEMO_POTENTIALS, (
        "the demo's avoiding episode: this processor computes other potentials than the ones "
        "recorded (AMD EPYC, replay mode)")


def _in_a_process(code: str, **env: str) -> str:
    """`code`'s output in a fresh interpreter started as from a shell: without the pinned
    variables this process has set (a child inherits them)."""
    pinned = numerics.pinned_environment()
    fresh = {k: v for k, v in os.environ.items() if k not in pinned}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env={**fresh, **env}, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def test_a_process_that_imported_numpy_first_computes_in_the_host_mode_and_says_so():
    code = ("import numpy, lgmd_sim; from lgmd_sim.core.machine import machine; "
            "print(machine()['numerics'])")
    assert _in_a_process(code) == ("host" if X86 else "replay")


@pytest.mark.skipif(not X86, reason="nothing is pinned off x86-64")
def test_the_host_mode_is_another_episode_on_a_processor_with_avx512():
    """Why the mode exists: NumPy's AVX-512 kernels round otherwise than its AVX2 ones, and
    a detector's potential parts (LoomSteer steers by it every frame)."""
    from numpy._core._multiarray_umath import __cpu_features__ as features

    if not features.get("AVX512F"):
        pytest.skip("no AVX-512 here: the host mode is the replay mode's code")
    code = ("import lgmd_sim; from lgmd_sim.benchmark.episode import Cell, episode; "
            "print(episode(Cell('RoughTerrainObstacles', 1.0, 'loom-steer', 'lgmd1', "
            "'robot-image'), 20000, resolution='small', cruise=0.6, horizon=2.0)"
            "['fingerprint']['sha256'])")
    assert _in_a_process(code, LGMD_SIM_NUMERICS="host") != GOLDEN["loom-steer"][1]


def test_two_fingerprints_part_at_the_link_where_they_first_differ():
    a, b = Fingerprint(), Fingerprint()
    frame = np.zeros((4, 4), np.uint8)
    for step in range(3 * EVERY):
        a.add({"frame": frame}, {"carrier_pos": [step, 0, 0]}, np.zeros(2), 0.5)
        b.add({"frame": frame}, {"carrier_pos": [step, 0, 0]}, np.zeros(2),
              0.5 if step != EVERY + 3 else 0.5000000001)
    assert first_difference(a.to_json(), a.to_json()) is None
    assert first_difference(a.to_json(), b.to_json()) == EVERY


# --- lgmd-sim verify ----------------------------------------------------------------------
