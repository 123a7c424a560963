"""Plots of the benchmark, from the results dictionary alone."""

from __future__ import annotations

import os
import warnings

import numpy as np

from skin_lab.bench.scoring import label

with warnings.catch_warnings():
    # matplotlib's parsers call pyparsing APIs it deprecates; nothing this project can fix.
    warnings.simplefilter('ignore', DeprecationWarning)
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt


def _save(fig, out_dir, name) -> str:
    os.makedirs(os.path.join(out_dir, 'img'), exist_ok=True)
    path = os.path.join('img', name)
    fig.savefig(os.path.join(out_dir, path), dpi=110, bbox_inches='tight')
    plt.close(fig)
    return path


def _pareto_front(points) -> set:
    """Return the indices of points not beaten on both cost and error by another point."""
    front = set()
    for i, (c, e) in enumerate(points):
        if not any((c2 <= c and e2 <= e) and (c2 < c or e2 < e)
                   for j, (c2, e2) in enumerate(points) if j != i):
            front.add(i)
    return front


def plot_pareto(summary, out_dir) -> str:
    """Plot mean azimuth error against us per frame, one panel per grid size."""
    grids = sorted({r['grid'] for r in summary})
    fig, axes = plt.subplots(1, len(grids), figsize=(4.2 * len(grids), 4), squeeze=False,
                             constrained_layout=True)
    methods = list(dict.fromkeys(r['method'] for r in summary))
    colours = {m: plt.cm.tab10(i % 10) for i, m in enumerate(methods)}
    for ax, n in zip(axes[0], grids):
        rows = [r for r in summary if r['grid'] == n and r['mean_error_deg'] is not None]
        front = _pareto_front([(r['median_us'], r['mean_error_deg']) for r in rows])
        for i, r in enumerate(rows):
            ax.scatter(r['median_us'], r['mean_error_deg'], color=colours[r['method']],
                       s=60 if i in front else 25, edgecolors='k' if i in front else 'none',
                       label=r['method'])
            ax.annotate(r['method'], (r['median_us'], r['mean_error_deg']), fontsize=7,
                        xytext=(3, 3), textcoords='offset points')
        pts = sorted((rows[i]['median_us'], rows[i]['mean_error_deg']) for i in front)
        if pts:
            ax.plot(*zip(*pts), 'k--', lw=0.8)
        ax.set_xscale('log')
        ax.set_yscale('log')
        ax.set_title(f'{n} x {n} taxels')
        ax.set_xlabel('us per frame (pipeline, median)')
        ax.grid(True, which='both', alpha=0.3)
    axes[0][0].set_ylabel('mean azimuth error [deg]')
    fig.suptitle('Accuracy against speed (all shifts and noise levels; dashed: Pareto front)')
    return _save(fig, out_dir, 'pareto.png')


def plot_seed_shifts(shifts, out_dir) -> str:
    """Scatter the measured raw shifts coloured by true azimuth (the seed's Figure 10)."""
    fig, axes = plt.subplots(1, len(shifts), figsize=(4.8 * len(shifts), 4.3), squeeze=False,
                             constrained_layout=True)
    for ax, (name, pts) in zip(axes[0], shifts.items()):
        if pts:
            arr = np.array(pts)
            sc = ax.scatter(arr[:, 0], arr[:, 1], c=arr[:, 2], cmap='hsv', vmin=0, vmax=360,
                            s=14)
            fig.colorbar(sc, ax=ax, label='true beta [deg]')
        ax.set_title(f'{name}: raw layer shift')
        ax.set_xlabel('dx [taxels]')
        ax.set_ylabel('dy [taxels]')
        ax.set_aspect('equal', adjustable='datalim')
        ax.grid(True, alpha=0.3)
    return _save(fig, out_dir, 'seed_shifts.png')


def plot_scaling(scale, out_dir) -> str:
    """Plot pipeline cost against taxel count and against the number of contacts."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for m in dict.fromkeys(r['method'] for r in scale['by_grid']):
        rows = [r for r in scale['by_grid'] if r['method'] == m]
        a.plot([r['taxels'] for r in rows], [r['median_us'] for r in rows], 'o-', label=m)
    a.axhline(100, color='g', ls=':', label='target 16x16 (100 us)')
    a.axhline(1000, color='r', ls=':', label='target 128x128 (1 ms)')
    a.set_xscale('log')
    a.set_yscale('log')
    a.set_xlabel('taxels per layer')
    a.set_ylabel('us per frame, 1 contact (median)')
    a.legend(fontsize=8)
    a.grid(True, which='both', alpha=0.3)
    for (m, n) in dict.fromkeys((r['method'], r['grid']) for r in scale['by_contacts']):
        rows = [r for r in scale['by_contacts'] if r['method'] == m and r['grid'] == n]
        b.plot([r['contacts'] for r in rows], [r['median_us'] for r in rows], 'o-',
               label=f'{m} {n}x{n}')
    b.set_yscale('log')
    b.set_xlabel('simultaneous presses')
    b.set_ylabel('us per frame (median)')
    b.legend(fontsize=8)
    b.grid(True, which='both', alpha=0.3)
    return _save(fig, out_dir, 'scaling.png')


def plot_e2e(e2e, out_dir) -> str:
    """Plot the latency percentiles of every layout at every rate."""
    fig, ax = plt.subplots(figsize=(7, 4))
    labels = [f'{label(r)}\n{r["rate_hz"] / 1000:g} kHz'.replace(', ', '\n') for r in e2e]
    x = np.arange(len(e2e))
    for k, key in enumerate(('p50', 'p99', 'max')):
        ax.bar(x + 0.27 * k, [r['latency_ms'][key] or 0 for r in e2e], 0.27, label=key)
    ax.axhline(2.0, color='r', ls=':', label='target p99 (2 ms)')
    ax.set_xticks(x + 0.27, labels)
    ax.set_yscale('log')
    ax.set_ylabel("scan's last byte -> contacts at subscriber [ms]")
    ax.legend()
    return _save(fig, out_dir, 'e2e_latency.png')


def plot_sigma(pairs, out_dir) -> str:
    """Scatter the default's reported azimuth sigma against its measured error, per scene."""
    fig, ax = plt.subplots(figsize=(5.5, 4.5), constrained_layout=True)
    kinds = list(dict.fromkeys(p[3] for p in pairs))
    for i, kind in enumerate(kinds):
        pts = np.array([(s, max(e, 1e-3)) for s, e, _, k in pairs if k == kind])
        ax.scatter(pts[:, 0], pts[:, 1], s=8, alpha=0.5, color=plt.cm.tab10(i), label=kind)
    if pairs:
        sig = np.array([p[0] for p in pairs])
        err = np.array([p[1] for p in pairs])
        # Binned RMS error: where it follows the diagonal, the reported sigma is honest.
        edges = np.geomspace(max(sig.min(), 1e-3), max(sig.max(), 1e-2), 9)
        centres, rms = [], []
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (sig >= lo) & (sig <= hi)
            if sel.sum() >= 3:
                centres.append(np.sqrt(lo * hi))
                rms.append(np.sqrt(np.mean(err[sel] ** 2)))
        ax.plot(centres, rms, 'k-o', lw=1.2, ms=4, label='RMS error per sigma bin')
        lim = [min(sig.min(), 0.01), max(sig.max(), err.max(), 1.0)]
        ax.plot(lim, lim, 'k--', lw=0.8, label='error = sigma')
    ax.set_xscale('log')
    ax.set_yscale('log')
    ax.set_xlabel('reported azimuth_sigma [deg]')
    ax.set_ylabel('measured azimuth error [deg]')
    ax.set_title('Default estimator over the family: reported sigma vs error')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, out_dir, 'sigma_vs_error.png')
