"""The grid and pitch a driver reads scans with, in the orders the board's words can arrive."""

from skin_driver.core.protocol.grid import SkinGrid
from skin_driver.core.protocol.wire import BoardInfo

UID = '0039001e3438510b34313939'


def board(rows=16, cols=16, pitch_m=0.005):
    return BoardInfo('nucleo-f446re', UID, '0.1.0', rows, cols, pitch_m, 1000)


def test_frames_before_the_information_frame_give_the_grid_and_wait_for_the_pitch():
    grid = SkinGrid()
    assert not grid.ready and 'grid and pitch' in grid.waiting_for()
    assert grid.see_frame(16, 16) == ''
    assert grid.shape == (16, 16) and not grid.ready
    assert "waiting for the board's pitch" in grid.waiting_for()
    assert grid.hear_board(board()) == ''
    assert grid.ready and grid.pitch_m == 0.005 and grid.waiting_for() == ''


def test_the_information_frame_first_gives_grid_and_pitch():
    grid = SkinGrid()
    assert grid.hear_board(board(8, 10, 0.004)) == ''
    assert (grid.shape, grid.pitch_m, grid.ready) == ((8, 10), 0.004, True)
    # A frame of the same grid changes nothing.
    assert grid.see_frame(8, 10) == '' and grid.shape == (8, 10)


def test_set_values_override_and_agreeing_ones_are_kept():
    grid = SkinGrid(16, 16, 0.005)
    assert grid.ready
    assert grid.hear_board(board(16, 16, 0.0050004)) == ''  # within the frame's micrometre
    assert grid.ready and grid.pitch_m == 0.005


def test_a_contradicted_setting_is_refused_naming_both_and_the_refusal_stands():
    grid = SkinGrid(0, 0, 0.006)
    grid.see_frame(16, 16)
    refusal = grid.hear_board(board())
    assert refusal.startswith("parameter 'pitch' is 6.000 mm but board nucleo-f446re says its "
                              'pitch is 5.000 mm: scans are not used')
    assert not grid.ready
    # The board repeating itself does not clear it.
    assert grid.hear_board(board()) == refusal and not grid.ready


def test_a_set_row_count_that_the_frames_contradict_is_refused():
    grid = SkinGrid(12, 0, 0.005)
    refusal = grid.see_frame(16, 16)
    assert refusal.startswith("parameter 'rows' is 12 but the board sends frames of 16x16")
    assert not grid.ready and grid.shape is None


def test_a_set_grid_that_the_information_frame_contradicts_is_refused():
    refusal = SkinGrid(16, 16).hear_board(board(12, 12))
    assert refusal.startswith("parameter 'rows' is 16; parameter 'cols' is 16 but board "
                              'nucleo-f446re says its grid is 12x12')
