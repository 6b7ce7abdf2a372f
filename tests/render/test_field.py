"""The particle-field renderer against closed forms (Beer-Lambert through a slab, splat weights) and its gradients
against central finite differences."""

import numpy as np
import pytest
import torch

from rheo.render.field import VoxelGrid, march, particle_fields, particles_to_grid


def test_splat_conserves_each_particles_value_and_fills_a_lattice_evenly():
    rng = np.random.default_rng(0)
    points = torch.as_tensor(rng.uniform(0.2, 0.8, (500, 3)))
    grid = VoxelGrid.around(points.numpy(), 0.05)
    sums = particles_to_grid(points, torch.ones(500, 1, dtype=torch.float64), grid)
    assert sums.sum().item() == pytest.approx(500.0, rel=1e-12)  # trilinear weights sum to one
    # one particle per voxel on the lattice offset by half a voxel: every interior node gets exactly 1
    lattice = torch.as_tensor(np.stack(np.meshgrid(*[np.arange(10) * 0.05 + 0.025] * 3, indexing="ij"), -1)
                              .reshape(-1, 3))
    grid = VoxelGrid((0.0, 0.0, 0.0), 0.05, (12, 12, 12))
    filled = particles_to_grid(lattice, torch.ones(len(lattice), 1, dtype=torch.float64), grid)[0]
    assert torch.allclose(filled[1:10, 1:10, 1:10], torch.ones(9, 9, 9, dtype=torch.float64))


def test_opacity_through_a_uniform_slab_follows_beer_lambert():
    grid = VoxelGrid((0.0, 0.0, 0.0), 0.01, (101, 101, 101))
    density = torch.zeros(grid.shape, dtype=torch.float64)
    density[30:71] = 5.0  # a slab 0.3 <= x <= 0.7: 0.4 thick
    colour = torch.zeros((3, *grid.shape), dtype=torch.float64)
    colour[0] = 1.0
    origins = torch.tensor([[-1.0, 0.5, 0.5], [-1.0, 0.2, 0.7]], dtype=torch.float64)
    dirs = torch.tensor([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], dtype=torch.float64)
    background = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    rgb, opacity = march(density, colour, grid, origins, dirs, background, step=0.001)
    expected = 1 - np.exp(-5.0 * 0.4)
    assert opacity.numpy() == pytest.approx([expected, expected], abs=0.01)
    assert rgb[0].numpy() == pytest.approx([expected, 0.0, 1 - expected], abs=0.01)
    # a ray that misses the grid sees the background
    rgb, opacity = march(density, colour, grid, torch.tensor([[-1.0, 2.0, 0.5]], dtype=torch.float64),
                         dirs[:1], background)
    assert opacity.item() == 0.0 and rgb[0].tolist() == [0.0, 0.0, 1.0]


def test_rendered_colour_gradients_match_finite_differences():
    rng = np.random.default_rng(1)
    positions = torch.as_tensor(rng.uniform(0.4, 0.6, (60, 3)), dtype=torch.float64).requires_grad_()
    density = torch.as_tensor(rng.uniform(20, 60, 60), dtype=torch.float64).requires_grad_()
    colour = torch.as_tensor(rng.uniform(0, 1, (60, 3)), dtype=torch.float64).requires_grad_()
    grid = VoxelGrid((0.3, 0.3, 0.3), 0.04, (11, 11, 11))
    origins = torch.as_tensor(np.c_[rng.uniform(0.42, 0.58, (40, 2)), np.full(40, -0.5)], dtype=torch.float64)
    dirs = torch.as_tensor(rng.normal(0, 0.05, (40, 3)) + np.array([0.0, 0.0, 1.0]), dtype=torch.float64)
    dirs = dirs / dirs.norm(dim=1, keepdim=True)
    target = torch.as_tensor(rng.uniform(0, 1, (40, 3)), dtype=torch.float64)
    white = torch.ones(3, dtype=torch.float64)

    def loss(p, d, c):
        rgb, _ = march(*particle_fields(p, d, c, grid), grid, origins, dirs, white)
        return ((rgb - target) ** 2).sum()

    value = loss(positions, density, colour)
    value.backward()
    for tensor, index in [(positions, (3, 0)), (positions, (17, 2)), (density, (5,)), (colour, (8, 1))]:
        h = 1e-6
        with torch.no_grad():
            tensor[index] += h
            up = loss(positions, density, colour).item()
            tensor[index] -= 2 * h
            down = loss(positions, density, colour).item()
            tensor[index] += h
        assert tensor.grad[index].item() == pytest.approx((up - down) / (2 * h), rel=1e-5, abs=1e-9)
