"""The bring-up kit's findings on synthetic frames, each fault with its expected finding."""

import numpy as np
import pytest

from skin_driver.tools.bringup import analysis

SHAPE = (8, 6)


def _idle(frames=200, seed=1):
    """Return an idle layer: 500 counts and independent noise of 3 counts on every taxel."""
    rng = np.random.default_rng(seed)
    return np.rint(500 + 3 * rng.standard_normal((frames,) + SHAPE))


def test_a_healthy_layer_has_no_finding():
    found = analysis.faults(_idle())
    assert found.count() == 0
    stats = analysis.noise(_idle())
    assert stats['mean_counts'] == pytest.approx(500, abs=0.5)
    assert stats['std_median'] == pytest.approx(3, rel=0.1)


def test_a_dead_taxel_reads_a_constant():
    stack = _idle()
    stack[:, 2, 4] = 0
    found = analysis.faults(stack)
    assert found.dead_taxels == [(2, 4)]
    assert found.count() == 1


def test_a_stuck_row_is_named_as_a_row_not_as_its_taxels():
    stack = _idle()
    stack[:, 5, :] = 4095
    found = analysis.faults(stack)
    assert found.stuck_rows == [5] and found.stuck_taxels == []
    assert found.count() == 1


def test_two_shorted_columns_read_alike():
    stack = _idle()
    stack[:, :, 3] = stack[:, :, 1]
    found = analysis.faults(stack)
    assert found.shorted_cols == [(1, 3)]
    assert found.count() == 1


def test_two_dead_rows_are_dead_not_shorted():
    stack = _idle()
    stack[:, 0, :] = 0
    stack[:, 7, :] = 0
    found = analysis.faults(stack)
    assert found.dead_rows == [0, 7] and found.shorted_rows == []


@pytest.mark.parametrize('origin, x_end, expected', [
    ((0, 0), (0, 5), (False, False, False)),     # as the skin frame expects
    ((0, 5), (0, 0), (False, False, True)),      # columns mirrored
    ((7, 0), (7, 5), (False, True, False)),      # rows mirrored (y down)
    ((0, 0), (7, 0), (True, False, False)),      # x runs along the rows: transposed
    ((7, 5), (0, 5), (True, True, True)),        # transposed and both flipped
])
def test_two_corner_presses_give_the_orientation(origin, x_end, expected):
    got = analysis.orientation(origin, x_end, SHAPE)
    assert (got['transpose'], got['flip_rows'], got['flip_cols']) == expected
    assert got['ok'] == (expected == (False, False, False))


def test_the_orientation_undone_puts_the_presses_where_the_skin_frame_has_them():
    # The board's image is the skin's transposed and flipped; applying the finding undoes it.
    skin = np.zeros((6, 6))
    skin[0, 0], skin[0, 5] = 1, 2                # the origin press, the +x press
    image = np.flipud(skin.T)
    o = np.unravel_index(np.argmax(image == 1), image.shape)
    x = np.unravel_index(np.argmax(image == 2), image.shape)
    got = analysis.orientation(o, x, image.shape)
    fixed = image.T if got['transpose'] else image
    fixed = np.flipud(fixed) if got['flip_rows'] else fixed
    fixed = np.fliplr(fixed) if got['flip_cols'] else fixed
    assert np.array_equal(fixed, skin)


def test_presses_on_opposite_corners_are_refused():
    with pytest.raises(ValueError, match='adjacent'):
        analysis.orientation((0, 0), (7, 5), SHAPE)


def test_the_ghost_is_the_next_rows_share_of_the_press():
    idle = np.full(SHAPE, 100.0)
    pressed = np.tile(idle, (4, 1, 1))
    pressed[:, 3, 2] += 1000
    pressed[:, 4, 2] += 50                       # carried over into the row scanned next
    got = analysis.ghost_fraction(idle, pressed)
    assert (got['row'], got['col']) == (3, 2)
    assert got['ghost'] == pytest.approx(0.05) and got['carry'] == pytest.approx(0.05)


def test_a_press_spreading_alike_both_ways_carries_nothing_over():
    idle = np.full(SHAPE, 100.0)
    pressed = np.tile(idle, (4, 1, 1))
    pressed[:, 3, 2] += 1000
    pressed[:, 2, 2] += 400                      # the press's own spread, both sides
    pressed[:, 4, 2] += 430                      # and 30 counts carried into the next row
    got = analysis.ghost_fraction(idle, pressed)
    assert got['ghost'] == pytest.approx(0.43) and got['carry'] == pytest.approx(0.03)
    pressed[:, 0, 2] += 5000                     # at the first row there is no row before
    assert analysis.ghost_fraction(idle, pressed)['carry'] is None


def _arrivals(late_s):
    """Return (device_us, host_s) of a board 50 ppm fast read with these delays."""
    host = np.linspace(0, 60, late_s.size) + 100.0
    return (host - 100.0) * (1 + 50e-6) * 1e6 + 12345, host + late_s


def test_the_clock_fit_finds_a_board_50_ppm_fast_through_late_reads():
    rng = np.random.default_rng(0)
    got = analysis.clock_ppm(*_arrivals(rng.exponential(0.004, 600)))   # late, never early
    assert got['ppm'] == pytest.approx(50, abs=5)
    assert got['points'] == 600 and got['late_ms'] > 0


def test_a_backlog_read_at_the_start_does_not_bend_the_clock():
    # The first 100 frames queued before the port was opened and arrive together, 0.5 s late
    # at first: a least-squares line through every read would find several thousand ppm.
    rng = np.random.default_rng(1)
    late = rng.exponential(0.002, 600)
    late[:100] += np.linspace(0.5, 0.0, 100)
    device_us, host = _arrivals(late)
    assert abs(np.polyfit(host, device_us / 1e6, 1)[0] - 1) * 1e6 > 1000
    assert analysis.clock_ppm(device_us, host)['ppm'] == pytest.approx(50, abs=5)


def test_the_clock_fit_needs_a_span():
    with pytest.raises(ValueError):
        analysis.clock_ppm([1, 2], [0.0, 1.0])


def test_a_rise_within_the_noise_is_no_press():
    idle = analysis.noise(_idle())
    pressed = _idle(frames=10, seed=2)
    with pytest.raises(ValueError, match='no press seen'):
        analysis.press_peak(idle, pressed)
    pressed[:, 6, 1] += 200
    assert analysis.press_peak(idle, pressed)[:2] == (6, 1)
