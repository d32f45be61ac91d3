"""Pictures of the learned representation: snapshots, latent sweeps, clusters, saliency maps."""

import matplotlib

matplotlib.use("Agg")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

import litl.robots  # noqa: E402
from litl.models.controller import MLPController  # noqa: E402
from litl.models.kmeans import fit_kmeans  # noqa: E402
from litl.models.vae import AutoencoderParams, ConvAutoencoder, make_observer  # noqa: E402
from litl.sim import make_rollout  # noqa: E402
from litl.viz import VizError  # noqa: E402
from litl.viz.latent import (  # noqa: E402
    cluster_colors,
    draw_clusters,
    draw_latent_sweeps,
    draw_snapshots,
)
from litl.viz.saliency import animate_saliency, saliency  # noqa: E402

GRID = (32, 32)
LATENT = 4
CHANNELS = (4, 4, 8, 8, 8)
ACTUATORS = 3


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def random_params(module, seed, *args, **kwargs):
    """Parameters of `module` drawn with numpy: `module.init` compiles threefry for every one of
    them, which takes seconds on CPU. Kernels ~ N(0, 1 / fan_in), biases ~ N(0, 0.1^2)."""
    rng = np.random.default_rng(seed)
    shapes = jax.eval_shape(module.init, jax.random.key(0), *args, **kwargs)

    def draw(leaf):
        fan_in = np.prod(leaf.shape[:-1]) if len(leaf.shape) > 1 else 100.0
        return jnp.asarray(rng.normal(size=leaf.shape) / np.sqrt(fan_in), leaf.dtype)

    return jax.tree.map(draw, shapes)


@pytest.fixture(scope="module")
def model():
    return ConvAutoencoder(GRID, latent_dim=LATENT, channels=CHANNELS)


@pytest.fixture(scope="module")
def observer(model):
    # A scale other than 1, so that a missing normalization shows.
    field = jnp.zeros((1,) + GRID + (2,))
    return AutoencoderParams(network=random_params(model, 0, field), scale=jnp.asarray(0.5))


@pytest.fixture(scope="module")
def controller():
    return MLPController(ACTUATORS, (8,))


@pytest.fixture(scope="module")
def controller_params(controller):
    return random_params(controller, 1, jnp.zeros(LATENT))


def blob_fields(count, grid=GRID, seed=0):
    """(count, *grid, d) random velocities on a box of nodes, exactly zero elsewhere."""
    rng = np.random.default_rng(seed)
    fields = np.zeros((count,) + grid + (len(grid),), np.float32)
    box = (slice(None),) + tuple(slice(n // 4, n // 2) for n in grid)
    fields[box] = rng.normal(size=fields[box].shape)
    return fields


def panels(fig, gid):
    return [ax for ax in fig.axes if ax.get_gid() == gid]


def test_snapshots_show_fields_codes_and_reconstructions(model, observer, tmp_path):
    fields = blob_fields(3)
    path = tmp_path / "deep" / "snapshots.png"
    fig = draw_snapshots(model, observer, fields, path)
    assert path.stat().st_size > 0
    velocity, code, recon = (panels(fig, g) for g in ("velocity", "latent", "reconstruction"))
    assert (len(velocity), len(code), len(recon)) == (3 * 2, 3, 3 * 2)
    # Computed independently (jitted: op by op, every primitive would compile on its own): fields
    # normalized by the scale, the decoded output multiplied back.
    decoded, mean, _ = jax.jit(model.apply)(observer.network, fields / 0.5)
    mean, decoded = np.asarray(mean), np.asarray(decoded) * 0.5
    np.testing.assert_allclose([p.get_height() for p in code[2].patches], mean[2], rtol=1e-5)
    # Panels go snapshot by snapshot, x then y; x along the image's columns, up along its rows.
    np.testing.assert_array_equal(velocity[2 * 1 + 1].images[0].get_array(), fields[1, ..., 1].T)
    np.testing.assert_allclose(
        recon[2 * 2 + 0].images[0].get_array(), decoded[2, ..., 0].T, rtol=1e-5, atol=1e-7
    )
    # Red negative, blue positive, on one symmetric range that shows the field: the inputs' 98th
    # percentile of |v|, so a lone fast node saturates instead of washing the field out.
    image = velocity[0].images[0]
    assert image.get_cmap().name == "RdBu" and image.norm.vmin == -image.norm.vmax > -np.inf
    speeds = np.abs(fields[fields != 0])
    assert image.norm.vmax == pytest.approx(np.percentile(speeds, 98), rel=1e-6)
    spiked = np.array(fields)
    spiked[0, 0, 0, 0] = 1e3 * speeds.max()
    spiked_image = panels(draw_snapshots(model, observer, spiked), "velocity")[0].images[0]
    assert spiked_image.norm.vmax < 2 * image.norm.vmax


def test_latent_sweeps_decode_scaled_one_hot_vectors(model, observer, tmp_path):
    values = np.array([-1.0, 0.25, 1.0])
    path = tmp_path / "sweeps.png"
    fig = draw_latent_sweeps(model, observer, values, path)
    assert path.stat().st_size > 0
    sweep = panels(fig, "sweep")
    assert len(sweep) == LATENT * len(values) * 2
    latent, value, component = 2, 1, 1
    z = np.zeros((1, LATENT), np.float32)
    z[0, latent] = values[value]
    decode = jax.jit(lambda network, z: model.apply(network, z, method="decode"))
    expected = np.asarray(decode(observer.network, z))[0] * 0.5
    shown = sweep[(latent * len(values) + value) * 2 + component].images[0].get_array()
    np.testing.assert_allclose(shown, expected[..., component].T, rtol=1e-5, atol=1e-7)


def test_3d_fields_are_drawn_as_their_mid_depth_slice():
    model = ConvAutoencoder((8, 8, 6), latent_dim=2, channels=(2, 2, 2, 2, 2))
    observer = AutoencoderParams(random_params(model, 0, jnp.zeros((1, 8, 8, 6, 3))), jnp.asarray(1.0))
    fields = blob_fields(1, grid=(8, 8, 6))
    fields[0, :, :, 3, 2] = np.arange(64).reshape(8, 8)  # the middle slice differs from the rest
    fig = draw_snapshots(model, observer, fields)
    velocity = panels(fig, "velocity")
    assert len(velocity) == 3  # x, y, z components
    np.testing.assert_array_equal(velocity[2].images[0].get_array(), fields[0, :, :, 3, 2].T)
    assert "mid-depth" in fig._suptitle.get_text()


def test_clusters_colour_particles_by_membership():
    robot = litl.robots.get("biped", dx=1 / 32)
    observer = fit_kmeans(robot.layout.positions, 4, seed=0)
    ax = draw_clusters(robot, observer)
    particles = next(a for a in ax.get_children() if a.get_gid() == "particles")
    membership = np.argmax(np.asarray(observer.averaging), axis=0)
    assert len(np.unique(membership)) == 4
    np.testing.assert_allclose(particles.get_facecolor(), cluster_colors(4)[membership])
    centers = next(a for a in ax.get_children() if a.get_gid() == "cluster_centers")
    np.testing.assert_allclose(centers.get_offsets(), observer.centers, rtol=1e-6)
    with pytest.raises(VizError, match="does not fit 'biped'"):
        draw_clusters(robot, fit_kmeans(robot.layout.positions[:50], 4))
    stacked = jax.tree.map(lambda a: jnp.stack([a, a]), observer)
    with pytest.raises(VizError, match="pick one seed"):
        draw_clusters(robot, stacked)


def test_saliency_is_gradient_times_field(model, observer, controller, controller_params):
    field = blob_fields(1, seed=3)[0]
    result = saliency(model, observer, controller, controller_params, field)
    assert result.shape == (ACTUATORS,) + GRID + (2,)
    actuator = 1

    def signal(f):
        mean, _ = model.apply(observer.network, f[None] / observer.scale, method="encode")
        return controller.apply(controller_params, mean[0])[actuator]

    expected = np.asarray(jax.jit(jax.grad(signal))(jnp.asarray(field))) * field
    np.testing.assert_allclose(result[actuator], expected, rtol=1e-4, atol=1e-8)
    assert np.abs(result[actuator]).max() > 0
    assert np.all(result[:, field.sum(-1) == 0] == 0)  # zero where the field is zero


def test_saliency_matches_central_differences(x64, model, observer, controller, controller_params):
    # The same weights in float64, where central differences are accurate.
    observer, params = jax.tree.map(lambda a: jnp.asarray(a, jnp.float64), (observer, controller_params))
    field = blob_fields(1, seed=4)[0].astype(np.float64)
    result = saliency(model, observer, controller, params, field)
    node, component, actuator, h = (10, 12), 0, 2, 1e-5

    @jax.jit
    def signal(f):
        mean, _ = model.apply(observer.network, f[None] / observer.scale, method="encode")
        return controller.apply(params, mean[0])[actuator]

    up, down = field.copy(), field.copy()
    up[node + (component,)] += h
    down[node + (component,)] -= h
    derivative = (float(signal(up)) - float(signal(down))) / (2 * h)
    np.testing.assert_allclose(
        result[(actuator,) + node + (component,)],
        derivative * field[node + (component,)],
        rtol=1e-5,
        atol=1e-12,
    )


def test_clocked_controller_needs_the_time(model, observer):
    clocked = MLPController(ACTUATORS, (8,), period=0.5)
    params = random_params(clocked, 1, jnp.zeros(LATENT), time=jnp.zeros(()))
    field = blob_fields(1)[0]
    with pytest.raises(VizError, match="pass the simulated time"):
        saliency(model, observer, clocked, params, field)
    early, late = (saliency(model, observer, clocked, params, field, time=t) for t in (0.0, 0.2))
    assert not np.allclose(early, late)


def test_saliency_animation_has_a_frame_per_snapshot(
    model, observer, controller, controller_params, tmp_path
):
    path = tmp_path / "out" / "saliency.gif"
    fields = blob_fields(5, seed=1)
    assert animate_saliency(model, observer, controller, controller_params, fields, path) == path
    with Image.open(path) as gif:
        assert gif.n_frames == 5
    animate_saliency(model, observer, controller, controller_params, fields, path, actuator=2, stride=2)
    with Image.open(path) as gif:
        assert gif.n_frames == 3
    assert [p.name for p in path.parent.iterdir()] == ["saliency.gif"]  # no temporary files left


def test_bad_inputs_fail_clearly(model, observer, controller, controller_params, tmp_path):
    fields = blob_fields(2)
    with pytest.raises(VizError, match=r"\(T, 32, 32, 2\)"):
        draw_snapshots(model, observer, fields[0])
    with pytest.raises(VizError, match=r"\(T, 32, 32, 2\)"):
        draw_snapshots(model, observer, fields[..., :1])
    with pytest.raises(VizError, match="field must have shape"):
        saliency(model, observer, controller, controller_params, fields)
    stacked = jax.tree.map(lambda a: jnp.stack([a, a]), observer)
    with pytest.raises(VizError, match="pick one seed"):
        draw_latent_sweeps(model, stacked)
    with pytest.raises(VizError, match="k-means baseline has no latent space"):
        draw_snapshots(model, fit_kmeans(np.random.default_rng(0).random((10, 2)), 2), fields)
    with pytest.raises(VizError, match="1D array"):
        draw_latent_sweeps(model, observer, values=np.ones((2, 2)))
    stacked_controller = jax.tree.map(lambda a: jnp.stack([a, a]), controller_params)
    with pytest.raises(VizError, match="pick one"):
        saliency(model, observer, controller, stacked_controller, fields[0])
    gif = tmp_path / "s.gif"
    with pytest.raises(VizError, match="use a .gif or .mp4"):
        animate_saliency(model, observer, controller, controller_params, fields, tmp_path / "s.avi")
    with pytest.raises(VizError, match=r"in \[0, 3\)"):
        animate_saliency(model, observer, controller, controller_params, fields, gif, actuator=3)
    with pytest.raises(VizError, match=r"times must have shape \(T,\) = \(2,\)"):
        animate_saliency(model, observer, controller, controller_params, fields, gif, times=[0.0])
    assert not list(tmp_path.iterdir())


def test_rollout_snapshots_animate(model, observer, tmp_path):
    """The pictures take what a rollout records: the biped's grid velocities every 5 steps."""
    robot = litl.robots.get("biped", dx=1 / 32)
    scene = robot.scene()
    clocked = MLPController(robot.n_actuators, (8,), period=0.1)
    params = random_params(clocked, 2, jnp.zeros(LATENT), time=jnp.zeros(()))
    observe = make_observer(model)

    def policy(policy_params, state, grid_velocity):
        features = observe(observer, state, grid_velocity)
        return clocked.apply(policy_params, features, time=state.step * scene.config.dt)

    rollout = jax.jit(
        make_rollout(
            scene.config, scene.body, policy, 15, snapshot_stride=5, observe=lambda state: (), remat=False
        )
    )
    snapshots = np.asarray(rollout(params, scene.design, scene.state)[1].snapshots)
    times = (np.arange(len(snapshots)) + 1) * 5 * scene.config.dt
    path = animate_saliency(model, observer, clocked, params, snapshots, tmp_path / "biped.gif", times=times)
    with Image.open(path) as gif:
        assert gif.n_frames == 3
    assert len(panels(draw_snapshots(model, observer, snapshots), "latent")) == 3
