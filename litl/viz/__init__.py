"""Pictures of robots and animations of rollouts (matplotlib; use the Agg backend headless).

`draw_robot` / `draw_robot_3d` draw a robot in the style of the paper's Fig. 4 insets;
`draw_body` draws a co-designed body beside the body as built (what its design space changed);
`record_rollout` simulates a robot and `animate_rollout` writes the result as a GIF or MP4 (a 3D
rollout framed on the robot's path, `rollout_limits`); `measure_gait` / `draw_gait` say how a
walker moved (its feet's lifts and slip, a side view).
The learned representation: `draw_snapshots` (Fig. 1), `draw_latent_sweeps` (Fig. 8),
`draw_clusters` (Fig. 7), and `saliency` / `animate_saliency` (saliency maps).
"""

from litl.viz.animation import animate_rollout, record_rollout
from litl.viz.gait import draw_gait, find_feet, measure_gait
from litl.viz.robots import (
    VizError,
    add_actuation_colorbar,
    draw,
    draw_robot,
    draw_robot_3d,
    particle_colors,
    rollout_limits,
)

__all__ = [
    "VizError",
    "add_actuation_colorbar",
    "animate_rollout",
    "draw",
    "draw_gait",
    "draw_robot",
    "draw_robot_3d",
    "find_feet",
    "measure_gait",
    "particle_colors",
    "record_rollout",
    "rollout_limits",
]

from litl.viz.bodies import draw_body  # noqa: E402
from litl.viz.latent import draw_clusters, draw_latent_sweeps, draw_snapshots  # noqa: E402
from litl.viz.saliency import animate_saliency, make_saliency, saliency  # noqa: E402

__all__ += [
    "animate_saliency",
    "draw_body",
    "draw_clusters",
    "draw_latent_sweeps",
    "draw_snapshots",
    "make_saliency",
    "saliency",
]
