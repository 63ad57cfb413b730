"""The MuJoCo jitter world: terrain, robot, camera carriers, obstacles, light, rendering.

The parameters (`lgmd_sim.world.params`) import no MuJoCo; `JitterWorld` does (after
choosing its GL backend, see `lgmd_sim.world.gl`) and is imported on first use. `scene`
compiles a world's model once, `randomise` rewrites it in place for each episode, and
`core` (`JitterWorld`) steps it and gives the frames (`render`) and the ground truth
(`truth`: what the carrier may hit); `carriers` moves the camera and `terrain` makes the
rough ground.

>>> from lgmd_sim.world import JitterWorld, SceneParams
>>> world = JitterWorld(SceneParams(carrier="handheld", jitter=1.0))
>>> world.reset(seed=0); world.step(1.0, 0.0); frame, truth = world.rgb, world.truth
"""

from typing import Any

from lgmd_sim.world.params import RESOLUTIONS, SceneParams

__all__ = ["RESOLUTIONS", "JitterWorld", "SceneParams"]


def __getattr__(name: str) -> Any:
    if name == "JitterWorld":
        from lgmd_sim.world.core import JitterWorld

        return JitterWorld
    raise AttributeError(f"module 'lgmd_sim.world' has no attribute {name!r}")
