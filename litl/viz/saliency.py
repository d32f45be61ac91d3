"""Saliency maps: which grid velocities each actuator's signal depends on.

As in the paper's supplemental video: the gradient of every actuator signal with respect to the
input grid velocities, multiplied point-wise by the velocities (gradient times input), through the
observer (encoder means of the scaled field) and the controller, exactly as the loop's policy
computes the actuation:

    saliency[a, node, c] = d u_a / d v[node, c] * v[node, c]

`animate_saliency` draws |saliency| summed over velocity components, one panel per actuator, for
every snapshot of a rollout. A 3D field is drawn as its mid-depth slice (axis 2).
"""

from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import matplotlib.animation as manimation
import matplotlib.colors as mcolors
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from litl.models.controller import MLPController
from litl.models.vae import AutoencoderParams, ConvAutoencoder, make_observer
from litl.viz.animation import SUFFIXES, animation_writer, save_animation
from litl.viz.latent import PICK_SEED, check_fields, check_observer
from litl.viz.robots import VizError

SALIENCY_CMAP = "magma"


def _make_actuation(model: ConvAutoencoder, controller: MLPController):
    """The loop's policy on a bare field: `actuation(observer_params, controller_params, field,
    time) -> (m,)`, the controller fed by the encoder means of field / scale."""
    observe = make_observer(model)

    def actuation(observer_params, controller_params, field, time):
        features = observe(observer_params, None, field)
        return controller.apply(controller_params, features.astype(field.dtype), time=time)

    return actuation


def make_saliency(model: ConvAutoencoder, controller: MLPController):
    """`saliency(observer_params, controller_params, field, time) -> (m, *grid, d)`; pure, jittable.

    `time` is the simulated time () for a controller with a clock (`period`), else None.
    """
    actuation = _make_actuation(model, controller)

    def saliency(observer_params, controller_params, field, time=None):
        # Reverse mode: one backward pass per actuator instead of one forward pass per velocity.
        jacobian = jax.jacrev(actuation, argnums=2)(observer_params, controller_params, field, time)
        return jacobian * field

    return saliency


def _check_controller(controller, controller_params, model, observer_params, field, time):
    """Trace the policy once (shapes only, nothing compiles) so that a mismatch fails clearly."""
    if not isinstance(controller, MLPController):
        raise VizError(f"controller must be an MLPController, got {type(controller).__name__}")
    if controller.period is not None and time is None:
        raise VizError("this controller has a clock (period): pass the simulated time(s)")
    actuation = _make_actuation(model, controller)
    try:
        out = jax.eval_shape(actuation, observer_params, controller_params, field, time)
    except Exception as error:  # flax reports a shape mismatch deep inside a Dense layer
        raise VizError(
            f"the controller parameters do not fit this controller on "
            f"{model.latent_dim} latent features (a run's stacked seeds? {PICK_SEED}): "
            f"{error}"
        ) from error
    if out.shape != (controller.n_actuators,):
        raise VizError(
            f"the controller returned shape {out.shape}, expected ({controller.n_actuators},): {PICK_SEED}"
        )


def _check_times(times, count):
    if times is None:
        return [None] * count
    times = np.asarray(times, np.float64)
    if times.shape != (count,):
        raise VizError(f"times must have shape (T,) = ({count},), one per snapshot, got {times.shape}")
    return list(times)


def saliency(
    model: ConvAutoencoder,
    observer_params: AutoencoderParams,
    controller: MLPController,
    controller_params,
    field,
    time=None,
) -> np.ndarray:
    """Gradient of every actuator signal w.r.t. the observed grid field, times the field.

    Args:
      model: the observer's autoencoder.
      observer_params: its parameters (one seed); the field is divided by their scale first.
      controller: the `MLPController` fed by the encoder means.
      controller_params: its parameters (one seed).
      field: (*grid_shape, d) the grid field the observer reads (a replay-buffer snapshot).
      time: () simulated time, needed by a controller with a clock (`period`).

    Returns:
      (m, *grid_shape, d) numpy saliency; zero wherever the field is zero.

    Raises:
      VizError: parameters of several seeds or of another model, a field that does not match the
        model's grid, or a missing time for a clocked controller.
    """
    check_observer(model, observer_params)
    field = jnp.asarray(check_fields(model, np.asarray(field)[None], "field")[0])
    _check_controller(controller, controller_params, model, observer_params, field, time)
    compute = jax.jit(make_saliency(model, controller))
    return np.asarray(compute(observer_params, controller_params, field, time))


def _magnitude_plane(saliency_maps) -> np.ndarray:
    """(p, *grid, d) saliency -> (p, nx, ny) |saliency| summed over components, a 3D grid sliced."""
    magnitude = np.abs(saliency_maps).sum(axis=-1)
    return magnitude if magnitude.ndim == 3 else magnitude[:, :, :, magnitude.shape[3] // 2]


def animate_saliency(
    model: ConvAutoencoder,
    observer_params: AutoencoderParams,
    controller: MLPController,
    controller_params,
    snapshots,
    path,
    actuator=None,
    times=None,
    fps: float = 10,
    stride: int = 1,
    dpi: int = 80,
) -> Path:
    """Write an animation of saliency maps over snapshots (``.gif`` always, ``.mp4`` with ffmpeg).

    Each panel shows, for one actuator, |saliency| summed over the velocity components, grid axis 0
    across and axis 1 up (a 3D field's mid-depth slice). A panel keeps one colour range over all
    frames (0 to its largest value), so that frames compare; actuators each have their own range.

    Args:
      model: the observer's autoencoder.
      observer_params: its parameters (one seed).
      controller: the `MLPController` fed by the encoder means.
      controller_params: its parameters (one seed).
      snapshots: (T, *grid_shape, d) raw grid velocities, e.g. a rollout's
        ``trajectory.snapshots``.
      path: output file; its suffix picks the format. Parent folders are created.
      actuator: an actuator index or a sequence of them to draw; None: every actuator.
      times: (T,) simulated time of each snapshot, needed by a controller with a clock. The
        policy sees a rollout's snapshot k (stride s) at time (k + 1) s dt.
      fps: frames per second.
      stride: draw every `stride`-th snapshot.
      dpi: resolution.

    Returns:
      The path written.

    Raises:
      VizError: an unknown suffix, .mp4 without ffmpeg, an actuator out of range, snapshots or
        times of the wrong shape, or parameters that do not fit the model and controller.
    """
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise VizError(f"cannot write an animation to {str(path)!r}: use a .gif or .mp4 file name")
    if not isinstance(stride, int) or stride < 1:
        raise VizError(f"stride must be a positive integer, got {stride!r}")
    if not fps > 0:
        raise VizError(f"fps must be positive, got {fps!r}")
    writer = animation_writer(path.suffix.lower(), fps)
    check_observer(model, observer_params)
    fields = check_fields(model, snapshots)
    times = _check_times(times, len(fields))
    m = controller.n_actuators if isinstance(controller, MLPController) else 0
    actuators = list(range(m)) if actuator is None else list(np.atleast_1d(actuator))
    if not actuators or any(not isinstance(a, (int, np.integer)) or not 0 <= a < m for a in actuators):
        raise VizError(f"actuator must be an index or indices in [0, {m}), got {actuator!r}")
    frames = list(range(0, len(fields), stride))
    _check_controller(controller, controller_params, model, observer_params, jnp.asarray(fields[0]), times[0])

    compute = jax.jit(make_saliency(model, controller))
    # (frames, panels, nx, ny): frame by frame, so memory stays that of one Jacobian.
    maps = np.stack(
        [
            _magnitude_plane(
                np.asarray(compute(observer_params, controller_params, jnp.asarray(fields[k]), times[k]))[
                    actuators
                ]
            )
            for k in frames
        ]
    )

    columns = min(len(actuators), 4)
    rows = -(-len(actuators) // columns)
    fig = Figure(figsize=(2.6 * columns, 2.4 * rows + 0.4), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    images = []
    for panel, a in enumerate(actuators):
        ax = fig.add_subplot(rows, columns, panel + 1)
        limit = float(maps[:, panel].max()) or 1.0  # an all-zero panel still needs a range
        images.append(
            ax.imshow(
                maps[0, panel].T,
                origin="lower",
                cmap=SALIENCY_CMAP,
                norm=mcolors.Normalize(0.0, limit),
                interpolation="nearest",
            )
        )
        ax.set_title(f"actuator {a}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_gid("saliency")
        fig.colorbar(images[-1], ax=ax, shrink=0.8)
    depth = f", mid-depth slice z = {model.grid_shape[2] // 2}" if model.dim == 3 else ""
    title = fig.suptitle("", fontsize=10)

    def update(index):
        for panel, image in enumerate(images):
            image.set_data(maps[index, panel].T)
        title.set_text(
            f"|saliency| summed over components{depth}: snapshot {frames[index] + 1} / {len(fields)}"
        )
        return [*images, title]

    animation = manimation.FuncAnimation(fig, update, frames=range(len(frames)), blit=False)
    save_animation(animation, path, writer, dpi)
    return path
