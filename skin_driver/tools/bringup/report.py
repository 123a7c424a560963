"""The bring-up report: report.md with PNG heatmaps, summary.json and dataset.npz."""

from __future__ import annotations

import io
import json
import os
import warnings

import numpy as np

from skin_driver.core.common.atomic import write_atomically
from skin_driver.core.estimation.data.dataset import save_dataset
from skin_driver.core.estimation.data.recording import Recording

with warnings.catch_warnings():
    # matplotlib's parsers call pyparsing APIs it deprecates; nothing this project can fix.
    warnings.simplefilter('ignore', DeprecationWarning)
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

# The pitch a dataset gets when the board never said its own (docs/protocol.md, version 1).
DEFAULT_PITCH_M = 0.005


def _png(out: str, name: str, fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=100, bbox_inches='tight')
    plt.close(fig)
    write_atomically(os.path.join(out, name), lambda f: f.write(buf.getvalue()), binary=True)
    return name


def _heatmaps(out: str, found: dict) -> str:
    fig, axes = plt.subplots(2, 2, figsize=(9, 8))
    for row, layer in zip(axes, ('top', 'bottom')):
        for ax, key in zip(row, ('mean', 'std')):
            # origin='lower': row 0 at the bottom, as y points up in the skin frame.
            im = ax.imshow(found['noise'][layer][key], origin='lower', cmap='viridis')
            ax.set_title(f'{layer}: idle {key} (counts)')
            ax.set_xlabel('column')
            ax.set_ylabel('row')
            fig.colorbar(im, ax=ax, shrink=0.8)
            for r, c in found['faults'][layer].dead_taxels:
                ax.plot(c, r, 'wx')
            for r, c in found['faults'][layer].stuck_taxels:
                ax.plot(c, r, 'r+')
    return _png(out, 'noise.png', fig)


def _presses(out: str, found: dict) -> str:
    idle = found['noise']['top']['mean']
    fig, axes = plt.subplots(1, len(found['presses']),
                             figsize=(3.2 * len(found['presses']), 3.2), squeeze=False)
    for ax, (step, frames) in zip(axes[0], found['presses']):
        ax.imshow(np.mean([f.top for f in frames], axis=0) - idle, origin='lower', cmap='magma')
        ax.set_title(f'top rise: {step}')
    return _png(out, 'presses.png', fig)


def _ghosting(out: str, found: dict) -> str:
    points = sorted((g['settle_us'], g['ghost'], g['carry']) for g in found['ghosting']
                    if 'ghost' in g and not isinstance(g['settle_us'], str))
    fig, ax = plt.subplots(figsize=(5, 3.5))
    if points:
        us, ghost, carry = zip(*points)
        ax.plot(us, ghost, 'o-', label='ghost (rows beside)')
        if None not in carry:
            ax.plot(us, carry, 's--', label='carry (next row - previous)')
        ax.legend()
    ax.set_xlabel('settle time (us)')
    ax.set_ylabel('fraction of the press')
    ax.set_title('ghosting against settle time')
    return _png(out, 'ghosting.png', fig)


def summary(found: dict) -> dict:
    """Return the findings as plain JSON values."""
    info = found['info']
    return {
        'port': found['port'],
        'board': info.text if info else None,
        'shape': list(found['shape']),
        'link': found['link'], 'clock': found['clock'],
        'noise': {k: {n: v for n, v in s.items() if n not in ('mean', 'std')}
                  for k, s in found['noise'].items()},
        'faults': {k: vars(v) for k, v in found['faults'].items()},
        'orientation': found['orientation'],
        'ghosting': found['ghosting'], 'stopped': found['stopped'],
    }


def markdown(s: dict, images: dict) -> str:
    """Return report.md's text from a summary() and the PNG names."""
    link, clock = s['link'], s['clock']
    lines = ['# Board bring-up report', '',
             f'Port `{s["port"]}`, board: `{s["board"] or "no information frame received"}`, '
             f'grid {s["shape"][0]} x {s["shape"][1]}.', '',
             *([f'**Stopped early**: {s["stopped"]}; the checks before it are complete.', '']
               if s['stopped'] else []),
             '## Link', '',
             f'{link["frames"]} frames in {link["host_s"]:.1f} s of host time '
             f'({link["frames_per_s"]:.1f} frames/s, {link["bytes_per_s"]:.0f} bytes/s; '
             f'{link["frames_per_device_s"]:.1f} frames per device second). Loss: '
             f'{link["seq_gaps"]} sequence gaps ({link["frames_missed"]} frames), '
             f'{link["crc_errors"]} CRC errors, {link["size_errors"]} size and '
             f'{link["version_errors"]} version/flag errors, {link["bytes_discarded"]} bytes '
             'discarded.', '', '## Clock', '',
             (f"The board's clock runs {clock['ppm']:+.0f} ppm against the host's over "
              f'{clock["span_s"]:.1f} s ({clock["points"]} reads, fitted through the earliest; '
              f'the median read is {clock["late_ms"]:.2f} ms later). A crystal is '
              'within about ±50 ppm; far more means a wrong clock (an emulated '
              'board falls behind and catches up: meaningless there).')
             if clock else 'Too few reads for a clock fit.', '', '## Idle noise', '']
    for layer, n in s['noise'].items():
        lines.append(f'- {layer}: mean {n["mean_counts"]:.1f} counts, std median '
                     f'{n["std_median"]:.2f}, max {n["std_max"]:.2f} at (row, col) '
                     f'{tuple(n["noisiest"])}')
    lines += ['', f'![idle noise]({images["noise"]})', '', '## Dead, stuck and shorted', '',
              'Dead: zero variance at idle. Stuck: idle mean within 40 counts of 4095. A line is '
              'dead or stuck when all its taxels are. Shorted: two lines whose mean difference is '
              'under a quarter of the noise (independent lines differ by about 1.1 sigma).', '']
    lines += _faults_text(s['faults'])
    orientation = s['orientation']
    lines += ['', '## Orientation', '',
              ('Not checked (--no-presses).' if orientation is None else
               f'Two corner presses: {orientation["text"]}.' + (
                   '' if orientation['layers_agree'] else
                   f' The bottom layer differs: {orientation["bottom"]}.'))]
    if 'presses' in images:
        lines += ['', f'![presses]({images["presses"]})']
    lines += ['', '## Settle time and ghosting', '',
              'The firmware takes its settle time at build time only (SKIN_BOARD_SETTLE_US in '
              'skin_board_pins.h): each point is one build flashed. Ghost: the rise on the rows '
              'beside a press at its column, as a fraction of the press; carry: the row sampled '
              "next minus the row before (the press's own spread cancels). The shortest settle "
              "whose carry matches the longest's is enough.", '']
    lines += [_ghost_line(g) for g in s['ghosting']]
    if not s['ghosting']:
        lines.append('Not checked (--no-presses).')
    if 'ghosting' in images:
        lines += ['', f'![ghosting]({images["ghosting"]})']
    lines += ['', '## Dataset', '',
              '`dataset.npz` (docs/dataset.md): the idle window as tare, every press as frames; '
              '`python -m skin_lab.evaluate dataset.npz` reads it.', '']
    return '\n'.join(lines)


def _ghost_line(g: dict) -> str:
    us = g['settle_us']
    head = f'- settle {us}: ' if isinstance(us, str) else f'- settle {us:g} us: '
    if 'ghost' not in g:
        return head + g['error']
    carry = 'n/a (an edge row)' if g['carry'] is None else f'{g["carry"]:+.3f}'
    return head + (f'press at ({g["row"]}, {g["col"]}) rising {g["press_counts"]:.0f} counts, '
                   f'ghost {g["ghost"]:.3f}, carry {carry}')


def _faults_text(faults: dict) -> list:
    lines = []
    for layer, found in faults.items():
        items = [f'{k.replace("_", " ")} {v}' for k, v in found.items() if v]
        lines.append(f'- {layer}: ' + ('; '.join(items) if items else 'none'))
    return lines


def dataset(found: dict):
    """Return the frames as a dataset: the idle window as tare, the presses as frames."""
    info = found['info']
    rec = Recording(tare_frames=len(found['idle']))
    if info is not None:
        rec.set_board(info.text)
    pitch = info.pitch_m if info else DEFAULT_PITCH_M
    frames = list(found['idle']) + [f for _, fs in found['presses'] for f in fs]
    if len(frames) == len(found['idle']):
        frames.append(found['idle'][-1])   # a dataset holds one frame or more
    for f in frames:
        rec.add(pitch, f.top, f.bottom)
    return rec.dataset()


def write_report(out: str, found: dict) -> str:
    """Write the report into directory out; return report.md's path."""
    os.makedirs(out, exist_ok=True)
    images = {'noise': _heatmaps(out, found)}
    if found['presses']:
        images['presses'] = _presses(out, found)
    if found['ghosting']:
        images['ghosting'] = _ghosting(out, found)
    s = summary(found)
    save_dataset(os.path.join(out, 'dataset.npz'), dataset(found))
    write_atomically(os.path.join(out, 'summary.json'),
                     lambda f: json.dump(s, f, indent=1, default=_plain))
    path = os.path.join(out, 'report.md')
    write_atomically(path, lambda f: f.write(markdown(s, images)))
    return path


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    raise TypeError(f'{type(value).__name__} is not JSON')
