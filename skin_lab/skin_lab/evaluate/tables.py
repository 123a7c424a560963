"""The evaluator's outputs: its text table, the contacts CSV and JSON-ready values."""

from __future__ import annotations

import csv
import math

from skin_driver.core.common.atomic import write_atomically
from skin_lab.evaluate.scoring import MethodRun, PAPER_TABLE, SEPARATE_TAXELS

__all__ = ['CONTACT_COLUMNS', 'write_contacts', 'format_table', 'json_safe']

CONTACT_COLUMNS = ('frame', 'rank', 'x_m', 'y_m', 'force_n', 'azimuth_deg', 'alpha_deg',
                   'direction_valid', 'confidence', 'shift_x_m', 'shift_y_m',
                   'azimuth_sigma_deg')


def write_contacts(path, run: MethodRun, frame_numbers=None) -> int:
    """
    Write one CSV row per reported contact of every frame (atomically); return the rows.

    ``frame_numbers`` gives each of the run's frames its index in the dataset (default 0, 1,
    ...; ``Dataset.scored_frames()`` for a dataset with a ``split``).
    """
    rows = []
    numbers = range(len(run.contacts)) if frame_numbers is None else frame_numbers
    for frame, contacts in zip((int(n) for n in numbers), run.contacts):
        for rank, c in enumerate(contacts):
            rows.append((frame, rank, c.x_m, c.y_m, c.force_n, math.degrees(c.azimuth_rad),
                         math.degrees(c.alpha_rad), int(c.direction_valid), c.confidence,
                         c.shift_m[0], c.shift_m[1], math.degrees(c.azimuth_sigma_rad)))

    def write(f):
        out = csv.writer(f, lineterminator='\n')
        out.writerow(CONTACT_COLUMNS)
        for row in rows:
            out.writerow([v if isinstance(v, int) else f'{v:.9g}' for v in row])
    write_atomically(path, write)
    return len(rows)


def _fmt(v, spec='.2f') -> str:
    return '-' if v is None else format(v, spec)


def format_table(report: dict) -> str:
    """
    Return the side-by-side text table of an :func:`evaluate` report.

    When the directions are the paper's eight, its published Table 1 stands in the last column.
    """
    names = list(report['methods'])
    lines = []
    if 'frames' in report:
        multi = report.get('multi_press_frames')
        cal = report.get('calibration_frames')
        lines += [f'frames {report["frames"]} ({report["normal_frames"]} normal, '
                  f'{report["tilted_frames"]} tilted'
                  + (f', {multi} with several presses' if multi else '')
                  + (f'; {cal} more calibrate, the others are scored' if cal else '')
                  + f'), map {report["shape"][0]}x{report["shape"][1]}', '']
    betas = {r['beta_deg'] for n in names for r in report['methods'][n]['per_beta']}
    paper = report.get('seed_experiment', True) and betas and betas <= set(PAPER_TABLE)
    head = f'{"beta [deg]":>10}' + ''.join(f'{n + " mean":>16}{"std":>8}{"valid":>8}'
                                           for n in names)
    lines.append(head + (f'{"paper mean":>13}{"std":>8}' if paper else ''))
    rows = {}
    for n in names:
        for r in report['methods'][n]['per_beta']:
            rows.setdefault(r['beta_deg'], {})[n] = r
    for beta in sorted(rows):
        line = f'{beta:>10.1f}'
        for n in names:
            r = rows[beta].get(n)
            line += (f'{_fmt(r and r["mean_error_deg"]):>16}{_fmt(r and r["std_error_deg"]):>8}'
                     f'{(str(r["valid"]) + "/" + str(r["frames"])) if r else "-":>8}')
        if paper:
            line += f'{PAPER_TABLE[beta][0]:>13.2f}{PAPER_TABLE[beta][1]:>8.2f}'
        lines.append(line)
    line = f'{"summary":>10}'
    for n in names:
        s = report['methods'][n]['summary']
        line += f'{_fmt(s["mean_error_deg"]):>16}{_fmt(s["std_error_deg"]):>8}' \
                f'{_fmt(s["valid_share"] and 100 * s["valid_share"], ".1f") + "%":>8}'
    if paper:
        line += f'{PAPER_TABLE["summary"][0]:>13.2f}{PAPER_TABLE["summary"][1]:>8.2f}'
    if rows:
        lines.append(line)
    else:
        lines[-1] = 'no frame holds a single tilted press: no Table 1'
    lines.append('')
    for n in names:
        s = report['methods'][n]['summary']
        cost = (f', {_fmt(s["us_per_frame"], ".1f")} us per frame (contacts included)'
                if s.get('us_per_frame') is not None else '')
        lines.append(f'{n}: max error {_fmt(s["max_error_deg"])} deg{cost}')
        if s.get('alpha_mean_error_deg') is not None:
            force = ''
            if s.get('force_mean_error_pct') is not None:
                force = (f'; |force| error {_fmt(s["force_mean_error_pct"])} % '
                         f'(std {_fmt(s["force_std_error_pct"])}, '
                         f'bias {_fmt(s["force_bias_pct"], "+.2f")})')
            lines.append(f'{" " * len(n)}  alpha error {_fmt(s["alpha_mean_error_deg"])} deg '
                         f'(std {_fmt(s["alpha_std_error_deg"])}, '
                         f'bias {_fmt(s["alpha_bias_deg"], "+.2f")}){force}')
    for n in names:
        ratio = report['methods'][n].get('ratio_to_oracle')
        if ratio:
            lines.append(f'{n}: error / oracle {_fmt(ratio["single"])} (single presses), '
                         f'{_fmt(ratio["multi"])} (several presses)')
    for n in names:
        lines += _extra_lines(n, report['methods'][n])
        for note in report['methods'][n].get('calibration_notes', []):
            lines.append(f'{n} calibration, {note}')
    if paper:
        lines.append('paper: Klimaszewski et al., Sensors 2019, 19, 4697, Table 1 '
                     '(real skin, Fanuc robot, alpha = 45 deg)')
    return '\n'.join(lines)


def _pct(v) -> str:
    return '-' if v is None else f'{100 * v:.1f} %'


def _extra_lines(name: str, method: dict) -> list:
    """Return the text lines of the large-shift valid share and the multi-press figures."""
    lines = []
    s = method['summary']
    if s.get('large_shift_frames'):
        lines.append(f'{name}: valid on {_pct(s["large_shift_valid_share"])} of the '
                     f'{s["large_shift_frames"]} single presses shifting >= 1 taxel')
    p = method.get('presses')
    if p:
        lines.append(f'{name}: {p["frames"]} frames with several presses: '
                     f'{_pct(p["found_share"])} of {p["presses"]} presses found; pairs >= '
                     f'{SEPARATE_TAXELS:g} taxels apart separate {_pct(p["separate_share_far"])} '
                     f'(merged {_pct(p["merged_share_far"])}, {p["pairs_far"]} pairs), '
                     f'closer {_pct(p["separate_share_close"])} ({p["pairs_close"]} pairs)')
        lines.append(f'{" " * len(name)}  per-press azimuth error {_fmt(p["mean_error_deg"])} '
                     f'deg (std {_fmt(p["std_error_deg"])}, weaker presses '
                     f'{_fmt(p["weaker_mean_error_deg"])}) on {_pct(p["valid_share"])} of '
                     f'{p["tilted_presses"]} tilted presses')
    return lines


def json_safe(obj):
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
