import sys, math
import numpy as np
from skin_driver.core.estimation.dataset import load_dataset
from skin_driver.core.estimation.prepared import prepared_estimator
from skin_driver.core.estimation import jointfit
d0 = load_dataset(sys.argv[1])
est, _ = prepared_estimator(d0, 'taxel_fit')
est = est.with_compiled(False)
d = d0.select(d0.scored_frames())
p = d.pitch_m
nbad = 0
for i in range(d.frames):
    pr = d.presses(i)
    if len(pr) < 2:
        continue
    jointfit.DEBUG.clear()
    est.process(d.top[i], d.bottom[i])
    if not jointfit.DEBUG:
        continue
    # truth shifts (row, col) in taxels for presses
    truth = []
    for q in pr:
        s = q['shift_m'] / p
        az = math.radians(q['azimuth_deg']) if q['alpha_deg'] > 0 else 0.0
        truth.append((q['y_m'] / p, q['x_m'] / p, s * math.sin(az), s * math.cos(az)))
    lines = []
    for order, centre, params, cost in jointfit.DEBUG:
        txt = []
        for k in range(len(centre)):
            # nearest press to this top centre
            j = min(range(len(truth)), key=lambda j: (truth[j][0]-centre[k][0])**2 + (truth[j][1]-centre[k][1])**2)
            t = truth[j]
            txt.append('c%d(%.1f,%.1f) fit(%.2f,%.2f) true(%.2f,%.2f)' % (k, centre[k][0], centre[k][1], params[2+2*k], params[3+2*k], t[2], t[3]))
        lines.append('  %s cost %.4g a %.3f sig %.2f | %s' % (order, cost, params[0], params[1], ' '.join(txt)))
    print('frame', i)
    print('\n'.join(lines))
