"""
The firmware's tools, built on first use.

A test skips, naming the missing program, where the firmware cannot be built or emulated (a
workstation without the ARM toolchain or QEMU; tools/setup-firmware.sh installs them, CI has
them).
"""

import pytest

from skin_driver.tools import firmware_board


def _need(qemu: bool) -> None:
    missing = firmware_board.missing_tools(qemu=qemu)
    if missing:
        pytest.skip(f'firmware: {", ".join(missing)} not installed (tools/setup-firmware.sh '
                    'installs what is missing)')


@pytest.fixture(scope='session')
def frame_dump():
    """Return the path of the host program that makes frames with the firmware core."""
    _need(qemu=False)
    return firmware_board.build_frame_dump()


@pytest.fixture(scope='session')
def board_dump():
    """Return the path of the host program that runs the firmware's main loop at given times."""
    _need(qemu=False)
    return firmware_board.build_board_dump()


@pytest.fixture(scope='session')
def nucleo_image():
    """Return the path of the Nucleo-F446RE image, built as ``make firmware`` builds it."""
    _need(qemu=False)
    from skin_driver.tools.rehost.board import build_nucleo_image
    return build_nucleo_image()


@pytest.fixture(scope='session')
def nucleo_usb_image():
    """Return the path of the Nucleo-F446RE's USB image, built as ``make firmware`` builds it."""
    _need(qemu=False)
    from skin_driver.tools.rehost.board import build_nucleo_image
    return build_nucleo_image(usb=True)


@pytest.fixture(scope='session')
def qemu_image():
    """Return the path of the emulated board's firmware image."""
    _need(qemu=True)
    return firmware_board.build_image()
