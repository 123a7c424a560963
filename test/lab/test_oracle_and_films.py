"""Tests of the oracle (the floor) and the wider skin physics: film turn-on, Hertz tips."""

import math

import numpy as np
import pytest

from skin_driver.core.sim.physics import (contact_radius_m, layer_shift_m, Press, render,
                                          render_expected, render_force, SkinModel)
from skin_driver.core.sim.skins import family_skin, held_out_skin
from skin_lab.oracle import fit_presses, oracle_contacts


def test_oracle_started_at_the_truth_stays_there_on_noise_free_counts():
    model = SkinModel(misalignment_m=(3e-4, -2e-4))
    press = Press(0.0377, 0.0391, 12.0, math.radians(40.0), math.radians(110.0), 0.003)
    counts = render_expected(model, [press])
    u, sigma = fit_presses(model, [press], counts)
    t = model.compliance_m_per_n * press.tangential_force_n / model.pitch_m
    assert u[0, 3:5] == pytest.approx((t * math.cos(press.beta_rad),
                                       t * math.sin(press.beta_rad)), abs=1e-6)
    assert u[0, 5] == pytest.approx(0.0, abs=1e-6)  # the indenter's own radius
    assert np.isfinite(sigma).all()


def test_oracle_fits_the_indenters_size_it_is_not_told():
    # Started from a tip 30 % too large, the fit finds the true one (a driver is never told it).
    model = SkinModel(noise_counts=0.0)
    truth = Press(0.0377, 0.0391, 12.0, math.radians(40.0), math.radians(110.0), 0.003)
    counts = render_expected(model, [truth])
    start = Press(truth.x_m, truth.y_m, truth.force_n, truth.alpha_rad, truth.beta_rad, 0.0039)
    u, _ = fit_presses(model, [start], counts)
    assert 0.0039 * math.exp(u[0, 5]) == pytest.approx(0.003, rel=0.02)


def test_oracle_finds_the_azimuth_of_a_noisy_frame_within_a_degree():
    model = family_skin('film').model
    press = Press(0.0412, 0.0366, 20.0, math.radians(45.0), math.radians(200.0), 0.004)
    top, bottom = render(model, [press], np.random.default_rng(3))
    contacts = oracle_contacts(model, [press], np.stack((top, bottom)))
    assert len(contacts) == 1
    error = abs((math.degrees(contacts[0].azimuth_rad) - 200.0 + 180.0) % 360.0 - 180.0)
    assert error < 1.0
    assert oracle_contacts(model, [], np.stack((top, bottom))) == []


def test_a_shift_off_the_map_has_no_direction_and_does_not_run_away():
    # A soft layer (held_out:0's 2.8 mm/N) pushed outward at the edge: the bottom imprint
    # leaves the map by some five taxels, so nothing in the frame tells how far.
    model = held_out_skin(0).model
    press = Press(0.0765, 0.040, 12.0, math.radians(60.0), math.radians(5.0), 0.004)
    top, bottom = render(model, [press], np.random.default_rng(1))
    (contact,) = oracle_contacts(model, [press], np.stack((top, bottom)))
    assert not contact.direction_valid
    assert contact.force_n == pytest.approx(press.normal_force_n, rel=0.05)
    assert math.hypot(*contact.shift_m) < 0.1  # a trust region, not thousands of taxels


def test_film_below_its_turn_on_pressure_reads_nothing_and_steps_on_at_the_rim():
    plain = SkinModel(noise_counts=0.0, cover_spread_m=0.0005)
    film = SkinModel(noise_counts=0.0, cover_spread_m=0.0005, turn_on_pa=4e4,
                     turn_on_ohm=3500.0)
    press = Press(0.0375, 0.0375, 6.0, 0.0, 0.0, 0.004)
    soft_top, _ = render_force(plain, [press])
    film_top, _ = render_force(film, [press])
    # Less load is sensed (the film is open where the pressure is low), never more.
    assert film_top.sum() < soft_top.sum()
    assert (film_top <= soft_top + 1e-12).all()
    counts = render_expected(film, [press])[0]
    fsr = film.fsr
    step = fsr.full_scale * fsr.r_series_ohm / (fsr.r_series_ohm + 3500.0)
    loaded = film_top > 0
    assert loaded.any() and (counts[loaded] >= step + film.baseline_counts - 1e-9).all()
    assert (counts[~loaded] == film.baseline_counts).all()
    with pytest.raises(ValueError):
        SkinModel(turn_on_ohm=3500.0)


def test_hertz_tip_grows_with_the_cube_root_of_the_load_and_the_zero_moves_with_it():
    model = SkinModel(hertz_reference_n=10.0, normal_shift_m_per_n=(1e-5, -2e-5))
    light = Press(0.04, 0.04, 10.0, radius_m=0.003)
    heavy = Press(0.04, 0.04, 80.0, radius_m=0.003)
    assert contact_radius_m(model, light) == pytest.approx(0.003)
    assert contact_radius_m(model, heavy) == pytest.approx(0.006)
    assert layer_shift_m(model, heavy) == pytest.approx((8e-4, -1.6e-3))
    assert (render_force(model, [heavy])[0] > 1e-3).sum() > (
        render_force(model, [light])[0] > 1e-3).sum()


def test_held_out_draws_hold_the_new_physics_and_named_skins_stay_put():
    drawn = [held_out_skin(i).model for i in range(12)]
    assert any(m.turn_on_pa > 0 for m in drawn) and any(m.turn_on_ohm > 0 for m in drawn)
    assert any(m.hertz_reference_n > 0 for m in drawn)
    assert any(any(m.normal_shift_m_per_n) for m in drawn)
    assert held_out_skin(4) == held_out_skin(4)
    assert family_skin('default').model.turn_on_pa == 0.0
