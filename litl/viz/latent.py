"""Pictures of the learned representation: velocity snapshots, latent sweeps and k-means clusters.

* `draw_snapshots` (paper Fig. 1): velocity-field snapshots, their latent codes (the encoder means
  the controller sees) and their reconstructions.
* `draw_latent_sweeps` (paper Fig. 8): the decoded one-hot latent vectors v e_i, v from -1 to 1.
* `draw_clusters` (paper Fig. 7): the k-means baseline's clusters on the rest configuration.

Saliency maps (the supplemental video) are in `litl.viz.saliency`.

Field pictures follow the paper: one panel per velocity component (x left, y right; z after them
in 3D), ``RdBu`` on a range symmetric about zero, so red is negative and blue positive. Grid axis 0
(x) is drawn horizontally and axis 1 (up) vertically, so every panel's image is the component's
(nx, ny) array transposed (``ax.images[0].get_array() == field[..., c].T``). A 3D field is drawn
as its mid-depth slice, ``field[:, :, nz // 2]``.

The observer parameters are those of one seed; a run's stacked seeds are picked with
``jax.tree.map(lambda a: a[i], tree)``. Figures are bare matplotlib `Figure`s (not pyplot's, so
nothing leaks when drawing many): Jupyter shows them when returned; scripts save them with `path=`
or ``fig.savefig``.
"""

from __future__ import annotations

from pathlib import Path

import jax
import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from litl.models.kmeans import KMeansObserver
from litl.models.vae import AutoencoderParams, ConvAutoencoder
from litl.viz.robots import VizError, draw, resolve

FIELD_CMAP = "RdBu"  # low (negative) red, high (positive) blue, as in the paper
COMPONENTS = "xyz"
PICK_SEED = "pick one seed first: jax.tree.map(lambda a: a[i], params)"


# ---------------------------------------------------------------------------- inputs


def check_observer(model, observer_params) -> None:
    """Raise `VizError` unless `observer_params` are one seed's parameters of the autoencoder."""
    if not isinstance(model, ConvAutoencoder):
        raise VizError(f"model must be a ConvAutoencoder, got {type(model).__name__}")
    if not isinstance(observer_params, AutoencoderParams):
        raise VizError(
            "observer_params must be the autoencoder's AutoencoderParams (the k-means "
            f"baseline has no latent space), got {type(observer_params).__name__}"
        )
    if np.ndim(observer_params.scale) != 0:
        raise VizError(f"observer_params hold {np.shape(observer_params.scale)} seeds; {PICK_SEED}")


def check_fields(model: ConvAutoencoder, fields, name: str = "snapshots") -> np.ndarray:
    """(T, *grid_shape, d) float fields matching the model, with T >= 1."""
    fields = np.asarray(fields)
    want = tuple(model.grid_shape) + (model.dim,)
    if fields.ndim != len(want) + 1 or fields.shape[1:] != want or len(fields) == 0:
        shape = ", ".join(map(str, want))
        raise VizError(
            f"{name} must have shape (T, *grid_shape, d) = (T, {shape}) with T >= 1 "
            f"for this model, got {fields.shape}"
        )
    if not np.issubdtype(fields.dtype, np.floating):
        raise VizError(f"{name} must be floating point, got {fields.dtype}")
    return fields


def encode_means(model: ConvAutoencoder, observer_params: AutoencoderParams, fields) -> np.ndarray:
    """(T, r) encoder means of raw fields (T, *grid, d): what the controller sees."""
    x = np.asarray(fields, np.asarray(observer_params.scale).dtype) / observer_params.scale
    # One compiled program: op by op, each of the network's primitives would compile on its own.
    encode = jax.jit(lambda network, x: model.apply(network, x, method="encode")[0])
    return np.asarray(encode(observer_params.network, x))


def decode_fields(model: ConvAutoencoder, observer_params: AutoencoderParams, z) -> np.ndarray:
    """(B, *grid, d) decoded fields of latents z (B, r), in the raw fields' units (times scale)."""
    z = np.asarray(z, np.asarray(observer_params.scale).dtype)
    decode = jax.jit(lambda network, z: model.apply(network, z, method="decode"))
    return np.asarray(decode(observer_params.network, z) * observer_params.scale)


# ---------------------------------------------------------------------------- panels


def field_plane(field) -> np.ndarray:
    """(nx, ny, d) plane to draw: a 2D field itself, a 3D field's mid-depth slice (axis 2)."""
    field = np.asarray(field)
    return field if field.ndim == 3 else field[:, :, field.shape[2] // 2]


# Velocity snapshots: the colour range is this percentile of |v| over the nodes the robot covers,
# so that a few fast edge nodes (light nodes at the body's rim) do not wash the body's motion out.
FIELD_PERCENTILE = 98.0


def _robust_norm(*fields) -> mcolors.Normalize:
    """Symmetric range at `FIELD_PERCENTILE` of the nonzero |values| (faster nodes saturate)."""
    values = np.concatenate([np.abs(np.asarray(f)).ravel() for f in fields])
    values = values[values > 0]
    limit = float(np.percentile(values, FIELD_PERCENTILE)) if values.size else 0.0
    return mcolors.Normalize(vmin=-(limit or 1.0), vmax=limit or 1.0)


def _symmetric_norm(*fields) -> mcolors.Normalize:
    # A zero field still gets a valid range (matplotlib warns on vmin == vmax).
    limit = max(float(np.max(np.abs(f))) if np.size(f) else 0.0 for f in fields) or 1.0
    return mcolors.Normalize(vmin=-limit, vmax=limit)


def _draw_components(axes, field, norm, gid: str) -> None:
    """Draw each velocity component of `field` (*grid, d) on its own Axes of `axes`."""
    plane = field_plane(field)
    for component, ax in enumerate(axes):
        ax.imshow(
            plane[..., component].T, origin="lower", cmap=FIELD_CMAP, norm=norm, interpolation="nearest"
        )
        ax.set_gid(gid)
        ax.set_xticks([])
        ax.set_yticks([])


def _new_figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path) -> None:
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path)


def _depth_note(model: ConvAutoencoder) -> str:
    return f" (mid-depth slice z = {model.grid_shape[2] // 2})" if model.dim == 3 else ""


# ---------------------------------------------------------------------------- Fig. 1


def draw_snapshots(
    model: ConvAutoencoder, observer_params: AutoencoderParams, snapshots, path=None
) -> Figure:
    """Velocity snapshots, their latent codes and reconstructions (paper Fig. 1).

    Column t shows snapshot t: on top its velocity components (x left, y right; x, y, z of the
    mid-depth slice for 3D), in the middle the latent code (encoder means, the controller's input)
    as bars, below the reconstruction D(mean) in the same units and on the same colour range as
    the input. The range is the 98th percentile of the inputs' nonzero |v| (`FIELD_PERCENTILE`):
    the few fastest nodes saturate rather than wash the rest of the field out. Fields are divided
    by ``observer_params.scale`` before encoding and the reconstruction multiplied back, as the
    observer does. One colour range, symmetric about zero,
    serves every field panel so that snapshots compare; one bar range serves every code.

    Args:
      model: the observer's autoencoder.
      observer_params: its parameters (one seed).
      snapshots: (T, *grid_shape, d) raw grid velocities, e.g. a few of a rollout's
        ``trajectory.snapshots`` (each takes d panels of width; pick 3 to 8).
      path: if given, also save the figure there (the suffix picks the format).

    Returns:
      The figure. Field Axes carry the gid ``"velocity"`` or ``"reconstruction"`` (T d each), the
      bar Axes ``"latent"`` (T).

    Raises:
      VizError: parameters that are not one seed's autoencoder parameters, or snapshots whose
        shape does not match the model's grid.
    """
    check_observer(model, observer_params)
    fields = check_fields(model, snapshots)
    means = encode_means(model, observer_params, fields)
    reconstructions = decode_fields(model, observer_params, means)
    count, d = len(fields), model.dim

    fig = _new_figure(1.4 * count * d + 1.0, 5.2)
    grid = fig.add_gridspec(3, count * d, height_ratios=(1.0, 0.7, 1.0))
    norm = _robust_norm(*[field_plane(f) for f in fields])
    bar_limit = float(np.max(np.abs(means))) * 1.1 or 1.0
    # Bars in the fields' colours: blue positive, red negative.
    cmap = plt.get_cmap(FIELD_CMAP)
    bar_colors = np.where(means[..., None] >= 0, cmap(0.85), cmap(0.15))
    field_axes = []
    for t in range(count):
        columns = range(t * d, (t + 1) * d)
        top = [fig.add_subplot(grid[0, c]) for c in columns]
        bottom = [fig.add_subplot(grid[2, c]) for c in columns]
        _draw_components(top, fields[t], norm, "velocity")
        _draw_components(bottom, reconstructions[t], norm, "reconstruction")
        for ax, label in zip(top, COMPONENTS, strict=False):  # "xyz": the first d
            ax.set_title(f"{t + 1}: v{label}", fontsize=8)
        code = fig.add_subplot(grid[1, t * d : (t + 1) * d])
        code.bar(np.arange(model.latent_dim), means[t], color=bar_colors[t])
        code.axhline(0.0, color="black", linewidth=0.5)
        code.set_ylim(-bar_limit, bar_limit)
        code.set_xticks(np.arange(model.latent_dim))
        code.tick_params(labelsize=7)
        code.set_gid("latent")
        field_axes += top + bottom
    fig.axes[0].set_ylabel("velocity", fontsize=8)
    fig.axes[d].set_ylabel("reconstruction", fontsize=8)
    next(ax for ax in fig.axes if ax.get_gid() == "latent").set_ylabel("latent", fontsize=8)
    fig.colorbar(
        plt.cm.ScalarMappable(norm=norm, cmap=FIELD_CMAP),
        ax=field_axes,
        shrink=0.6,
        extend="both",
        label="velocity (red -, blue +)",
    )
    fig.suptitle(f"snapshots, latent codes and reconstructions{_depth_note(model)}", fontsize=10)
    _save(fig, path)
    return fig


# ---------------------------------------------------------------------------- Fig. 8


def draw_latent_sweeps(
    model: ConvAutoencoder,
    observer_params: AutoencoderParams,
    values=(-1.0, -0.5, 0.0, 0.5, 1.0),
    path=None,
    order=None,
) -> Figure:
    """Decoded one-hot latent vectors, each latent swept over `values` (paper Fig. 8).

    Row i shows D(v e_i) for each v in `values` (left to right), each box its velocity components
    side by side (x, y; x, y, z of the mid-depth slice for 3D), in the raw fields' units (the
    decoder's output times ``observer_params.scale``). Each row has its own colour range,
    symmetric about zero: the paper's normalized rows, so that a latent whose decoding is weak
    still shows its mode.

    Args:
      model: the observer's autoencoder.
      observer_params: its parameters (one seed).
      values: (V,) latent values to decode.
      path: if given, also save the figure there.
      order: the latents' rows, top to bottom (default 0, 1, ..., r - 1; e.g. by significance,
        `litl.report.latent_modes`); each row is labelled with its latent's index.

    Returns:
      The figure; its field Axes carry the gid ``"sweep"``, row by row (r rows of V d Axes).

    Raises:
      VizError: parameters that are not one seed's autoencoder parameters, or values that are not
        a non-empty 1D array of finite numbers.
    """
    check_observer(model, observer_params)
    values = np.asarray(values, np.float64)
    if values.ndim != 1 or len(values) == 0 or not np.all(np.isfinite(values)):
        raise VizError(f"values must be a non-empty 1D array of finite numbers, got {values!r}")
    r, d, count = model.latent_dim, model.dim, len(values)
    order = list(range(r)) if order is None else [int(i) for i in order]
    if sorted(order) != list(range(r)):
        raise VizError(f"order must list each of the {r} latents once, got {order}")
    # Row-major: latent i, value j is row i * V + j.
    one_hot = (np.eye(r)[:, None, :] * values[None, :, None]).reshape(r * count, r)
    decoded = decode_fields(model, observer_params, one_hot).reshape(
        (r, count) + tuple(model.grid_shape) + (d,)
    )

    fig = _new_figure(1.2 * count * d + 1.0, 1.2 * r + 0.8)
    grid = fig.add_gridspec(r, count * d)
    for row_index, i in enumerate(order):
        norm = _symmetric_norm(*[field_plane(f) for f in decoded[i]])
        row = []
        for j in range(count):
            axes = [fig.add_subplot(grid[row_index, j * d + c]) for c in range(d)]
            _draw_components(axes, decoded[i, j], norm, "sweep")
            if row_index == 0:
                for ax, label in zip(axes, COMPONENTS, strict=False):  # "xyz": the first d
                    ax.set_title(f"{values[j]:+.2g}: v{label}", fontsize=8)
            row += axes
        row[0].set_ylabel(f"z{i}", fontsize=8)
        fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=FIELD_CMAP), ax=row, shrink=0.8, aspect=10)
    fig.suptitle(f"decoded one-hot latents{_depth_note(model)} (red -, blue +)", fontsize=10)
    _save(fig, path)
    return fig


# ---------------------------------------------------------------------------- Fig. 7


def cluster_labels(kmeans_observer: KMeansObserver) -> np.ndarray:
    """(n,) cluster of every particle: the row of `averaging` that holds it."""
    return np.argmax(np.asarray(kmeans_observer.averaging), axis=0)


def cluster_colors(k: int) -> np.ndarray:
    """(k, 4) RGBA: a distinct colour per cluster."""
    cmap = plt.get_cmap("tab10" if k <= 10 else "tab20")
    return cmap(np.arange(k) % cmap.N) if k <= 20 else plt.get_cmap("hsv")(np.arange(k) / k)


def draw_clusters(robot, kmeans_observer: KMeansObserver, ax=None):
    """The k-means baseline's clusters on the robot's rest configuration (paper Fig. 7).

    Particles are coloured by cluster (the row of ``averaging`` that holds them), cluster centres
    are marked with black-edged circles in their cluster's colour. Walls are drawn as in
    `draw_robot`; a 3D robot is drawn as in `draw_robot_3d`.

    Args:
      robot: the `Robot` (or `Layout`) the observer was fitted on.
      kmeans_observer: a `KMeansObserver` (one seed) with averaging (k, n) and centers (k, d).
      ax: Axes to draw on (3D for a 3D robot); None: a new figure.

    Returns:
      The Axes. Particles are the artist with gid ``"particles"``, centres ``"cluster_centers"``.

    Raises:
      VizError: an observer that is not one seed's `KMeansObserver` of this robot's particles.
    """
    name, layout, _, _ = resolve(robot)
    if not isinstance(kmeans_observer, KMeansObserver):
        raise VizError(f"expected a KMeansObserver, got {type(kmeans_observer).__name__}")
    averaging = np.asarray(kmeans_observer.averaging)
    centers = np.asarray(kmeans_observer.centers)
    if averaging.ndim != 2 or centers.ndim != 2:
        raise VizError(f"the observer holds {averaging.shape[:-2]} seeds; {PICK_SEED}")
    k = len(centers)
    if averaging.shape != (k, layout.n_particles) or centers.shape[1] != layout.dim:
        raise VizError(
            f"the observer (averaging {averaging.shape}, centers {centers.shape}) does "
            f"not fit {name!r} with {layout.n_particles} particles in {layout.dim}D"
        )
    ax = draw(robot, ax, show_targets=False)
    labels = cluster_labels(kmeans_observer)
    colors = cluster_colors(k)
    particles = next(a for a in ax.get_children() if a.get_gid() == "particles")
    particles.set_facecolor(colors[labels])
    if layout.dim == 3:
        from litl.viz.robots import to_plot_3d

        ax.scatter(
            *to_plot_3d(centers).T,
            s=80,
            c=colors,
            edgecolors="black",
            linewidths=1.5,
            zorder=5,
            gid="cluster_centers",
        )
    else:
        ax.scatter(
            centers[:, 0],
            centers[:, 1],
            s=80,
            c=colors,
            edgecolors="black",
            linewidths=1.5,
            zorder=5,
            gid="cluster_centers",
        )
    ax.set_title(f"{name}: k-means clusters (k = {k})")
    return ax
