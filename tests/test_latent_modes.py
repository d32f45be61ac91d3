"""Fig. 8's question (`litl.report.latent_modes`): the rigid fraction of a field has known answers,
and a run's newest checkpoint gives each latent's significance, mode and rigid fraction."""

import json

import numpy as np
import pytest

from litl.loop import run
from litl.report.latent_modes import LatentModesError, main, rigid_fraction
from tests.loop.tiny import tiny_config, tiny_robot

DX = 0.1


def disc(shape=(24, 20), centre=(11.0, 9.0), radius=6.0):
    """(*shape) weights of a disc, and the (*shape, 2) positions relative to its centre."""
    index = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), -1).astype(float)
    relative = (index - np.asarray(centre)) * DX
    return (np.linalg.norm(relative, axis=-1) < radius * DX).astype(float), relative


def test_translations_and_rotations_are_rigid_and_a_stretch_or_shear_is_not():
    weight, r = disc()
    spin = np.stack([-r[..., 1], r[..., 0]], -1)
    translation = np.broadcast_to([0.3, -0.2], r.shape)
    assert rigid_fraction(translation + 2.0 * spin, weight, DX) == pytest.approx(1.0, abs=1e-9)
    # A uniform expansion and a pure shear have no rigid part about the centroid.
    assert rigid_fraction(r, weight, DX) == pytest.approx(0.0, abs=1e-9)
    shear = np.stack([r[..., 1], r[..., 0]], -1)
    assert rigid_fraction(shear, weight, DX) == pytest.approx(0.0, abs=1e-9)
    # Half the energy rigid, half a stretch: in between.
    mixed = spin / np.sqrt(np.sum(weight[..., None] * spin**2)) + r / np.sqrt(
        np.sum(weight[..., None] * r**2)
    )
    assert rigid_fraction(mixed, weight, DX) == pytest.approx(0.5, abs=1e-6)
    # Outside the weights nothing counts.
    assert rigid_fraction(np.where(weight[..., None] > 0, spin, 5.0), weight, DX) == pytest.approx(1.0)


def test_a_3d_rotation_is_rigid():
    index = np.stack(np.meshgrid(*[np.arange(8)] * 3, indexing="ij"), -1).astype(float)
    r = (index - 3.5) * DX
    field = np.cross([0.2, -1.0, 0.5], r) + [0.0, 0.1, 0.0]
    assert rigid_fraction(field, np.ones((8, 8, 8)), DX) == pytest.approx(1.0, abs=1e-9)
    assert rigid_fraction(r, np.ones((8, 8, 8)), DX) == pytest.approx(0.0, abs=1e-9)


def test_bad_fields_are_refused():
    weight, r = disc()
    with pytest.raises(LatentModesError, match="do not match"):
        rigid_fraction(r[:-1], weight, DX)
    with pytest.raises(LatentModesError, match="non-negative"):
        rigid_fraction(r, -weight, DX)
    assert np.isnan(rigid_fraction(np.zeros_like(r), weight, DX))


def test_a_runs_latents_ordered_by_significance_with_their_modes(tmp_path, capsys):
    run_dir = tmp_path / "run"
    run(tiny_robot(), tiny_config(loop={"episodes": 1}), run_dir, progress=False)
    assert main([str(run_dir), "--seed", "1", "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "latent_modes.json").read_text())
    r = 4  # the tiny VAE's latents
    assert sorted(summary["order"]) == list(range(r)) and summary["seed"] == 1
    variances = [summary["variance"][i] for i in summary["order"]]
    assert variances == sorted(variances, reverse=True)
    assert all(0.0 <= f <= 1.0 + 1e-9 for f in summary["rigid_fraction"])
    assert 0.0 <= summary["snapshot_rigid_fraction"] <= 1.0 and summary["snapshots"] >= 2
    assert (tmp_path / "out" / "latent_modes.png").stat().st_size > 0
    # Bad input: a seed the run does not have, a directory that is not a run.
    assert main([str(run_dir), "--seed", "7"]) == 2
    assert "the run has seeds [0, 1]" in capsys.readouterr().err
    assert main([str(tmp_path / "nowhere")]) == 2
    assert "not a litl run directory" in capsys.readouterr().err
