"""Pictures of robots and animations of rollouts (matplotlib; use the Agg backend headless).

`draw_robot` / `draw_robot_3d` draw a robot in the style of the paper's Fig. 4 insets;
`record_rollout` simulates a robot and `animate_rollout` writes the result as a GIF or MP4.
"""

from litl.viz.animation import animate_rollout, record_rollout
from litl.viz.robots import (
    VizError, add_actuation_colorbar, draw, draw_robot, draw_robot_3d, particle_colors,
)

__all__ = [
    "VizError", "add_actuation_colorbar", "animate_rollout", "draw", "draw_robot",
    "draw_robot_3d", "particle_colors", "record_rollout",
]
