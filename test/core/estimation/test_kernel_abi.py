"""The kernel's binary interface: structs checked against the library, refusals, finding it."""

import ctypes
import os
import subprocess
import sys

import numpy as np
import pytest

from skin_driver.core.estimation.scan import kernel
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig


def test_the_library_is_the_versioned_one_its_layout_the_mirrors():
    lib = kernel.load_library()
    assert lib._name.endswith(f'libskin_kernel.so.{kernel.ABI_VERSION}')
    assert lib.sk_abi_version() == kernel.ABI_VERSION
    kernel._check_layout(lib, lib._name)  # raises on any difference


def test_a_changed_layout_is_refused_even_under_python_O():
    # The check is a raise, not an assert: `python -O` keeps it.
    code = ('import ctypes\n'
            'from skin_driver.core.estimation.scan import kernel\n'
            'class Status(ctypes.Structure):\n'
            "    _fields_ = [('revived', ctypes.c_int), ('found', ctypes.c_int),\n"
            "                ('censored', ctypes.c_int)]\n"
            "kernel._MIRRORS['sk_status'] = Status\n"
            'try:\n'
            '    kernel.load_library()\n'
            'except kernel.KernelMismatch as err:\n'
            '    print(err)\n')
    out = subprocess.run([sys.executable, '-O', '-c', code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert 'sk_status.revived' in out.stdout and 'sk_status.found' in out.stdout


def test_the_missing_library_error_says_where_it_looked():
    code = ('from skin_driver.core.estimation.scan import kernel\n'
            'try:\n'
            '    kernel.load_library()\n'
            'except kernel.KernelMissing as err:\n'
            '    print(err)\n')
    env = {**os.environ, kernel.LIBRARY_VARIABLE: '/nowhere/libskin_kernel.so.9'}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env)
    assert 'no /nowhere/libskin_kernel.so.9' in out.stdout and 'make setup' in out.stdout


def test_the_library_is_found_without_the_ament_index():
    # A source checkout next to its workspace: no AMENT_PREFIX_PATH, no ament_index lookup.
    code = ('import sys\n'
            "sys.modules['ament_index_python'] = None\n"
            'from skin_driver.core.estimation.scan import kernel\n'
            'print(kernel.load_library()._name)\n')
    env = {k: v for k, v in os.environ.items() if k not in ('AMENT_PREFIX_PATH',
                                                            kernel.LIBRARY_VARIABLE)}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith(f'libskin_kernel.so.{kernel.ABI_VERSION}')


def _new(settings, size=None):
    lib = kernel.load_library()
    n = 2 * settings.rows * max(settings.cols, 1)
    arrays = [np.zeros(max(n, 1)) for _ in range(3)]
    dead = np.zeros(max(n, 1), dtype=np.uint8)
    tables = np.zeros(2 * (max(settings.full_scale, 0) + 1))
    handle = ctypes.c_void_p()
    message = ctypes.create_string_buffer(256)
    status = lib.sk_new(ctypes.byref(settings), ctypes.sizeof(settings) if size is None else size,
                        *(ctypes.c_void_p(a.ctypes.data) for a in arrays), None,
                        ctypes.c_void_p(dead.ctypes.data), ctypes.c_void_p(tables.ctypes.data),
                        ctypes.byref(handle), message, len(message))
    if handle:
        lib.sk_free(handle)
    return status, bool(handle), message.value.decode()


def _settings(**changes):
    values = {'rows': 4, 'cols': 4, 'max_contacts': 4, 'full_scale': 4095, 'pitch_m': 0.005,
              'compliance_m_per_n': 7e-4, 'fill_factor': 0.9}
    values.update(changes)
    return kernel.Settings(**values)


def test_usable_settings_make_a_kernel():
    assert _new(_settings()) == (0, True, '')


@pytest.mark.parametrize('changes, words', [
    ({'method': 7}, 'unknown shift method 7'),
    ({'method': -1}, 'unknown shift method -1'),
    ({'rows': 0}, 'maps of 0 x 4'),
    ({'full_scale': 0}, 'full scale 0'),
    ({'max_contacts': -1}, 'max_contacts -1'),
    ({'pitch_m': 0.0}, 'must be positive'),
])
def test_unusable_settings_are_refused_with_a_message(changes, words):
    status, made, message = _new(_settings(**changes))
    assert status == kernel._BAD_SETTINGS and not made and words in message


def test_settings_of_another_size_are_refused():
    status, made, message = _new(_settings(), size=ctypes.sizeof(kernel.Settings) - 8)
    assert status == kernel._BAD_SETTINGS and not made and 'bytes' in message


def test_an_unknown_method_name_is_refused_before_the_library():
    est = ContactEstimator(EstimatorConfig())
    spec = kernel.KernelSettings(est._kernel_settings(), 'seed', *est.conditioning.state((4, 4)))
    with pytest.raises(ValueError, match='no compiled shift method'):
        kernel.Kernel(spec)


def test_records_are_read_by_name():
    assert kernel.Record._fields == tuple(name for name, _ in kernel.ContactRecord._fields_)
