"""Benchmark: a user's robot, end to end: discover on its logs, then predict held-out missions.

What a user does with the library, on logs whose physics the project did not write:

1. ``discover`` (``ep.discover``, the ``discover`` command) on the training missions, and
   the model it writes (``EnergyModel.save``), read back from the file;
2. for each held-out mission, the energy of its logged poses (``follow.walked_path``: the
   log's ``x, y, yaw`` with their times ``t``, one every ``--pose-every`` s) over the map,
   by ``energy.path_energy`` (what ``energy --waypoints`` runs, with times), with the
   mission's own channel values (``--set load_kg=...``), and its 90 % interval as the
   ``energy`` command gives it (``uncertainty.domain_report`` of the path, then
   ``uncertainty.path_trust`` with the path's duration and that report: the measured
   growth beyond each range, the mean-power check, and whether a battery decision is
   given); beside it the same report without the mean-power check, and the interval of
   the share outside only (what this benchmark printed before it used the report);
3. against the battery energy the mission measured (``measurements.run_energies``: the
   sum of voltage x current x dt).

Reported per mission and in summary: median error, 90th percentile of ``|error|``, the
share of missions whose measured energy lies in the nominal 90 % interval, and
``discover``'s final held-out power RMSE with its noise floor (estimated from the logs;
for simulated missions also the simulator's TRUE floor, ``Campaign.noise_floor``),
beside the targets of issue 28 (median within +-1.5 %, p90 within 5 %, coverage 85-95 %,
final RMSE within 1.2x the floor).

Data sets:

- ``robot-b``: ``--field-logs DIR`` holding ``train/``, ``test/`` and ``ridge.tif``
  (default ``../shared/field-logs/robot-b`` beside the repository; ``tests/fixtures/
  robot_b`` is its small subset, for a quick run);
- ``sim-load-S``: missions simulated with the ``load`` effect (``simulate_missions``,
  seed ``S``, loads ``--loads``), ``--missions`` for discover and ``--held-out`` more
  (seed ``S + 1000``) over the same synthetic DEM, logged without the altitude ``z``
  (as field mission logs). ``--campaigns N`` runs seeds 0..N-1.

Baseline side by side: the same model on EVERY logged pose as the log holds it
(``--pose-every 0``: no ``fresh_poses``), the way a user writing the log's rows as
waypoints would get it. A localisation slower than the log repeats each pose until the
next arrives; priced with the repeats' times the robot stands and then sprints.

Run::

    python benchmarks/bench_field_logs.py --field-logs ../shared/field-logs/robot-b \
        --campaigns 3     # robot-b + 3 campaigns of 30 + 20 missions x 120 s (~15 min)
    python benchmarks/bench_field_logs.py --campaigns 0          # robot-b only (~1 min)
    python benchmarks/bench_field_logs.py --field-logs tests/fixtures/robot_b --campaigns 0
    python benchmarks/bench_field_logs.py --no-field --phases varied --missions 60 \
        --duration 60     # the discovery campaign (MissionConfig.varied), 20 held out
    python benchmarks/bench_field_logs.py --json

Measured (2 shared cores; the per-mission tables with ``--per-mission``). The robot-b rows
and the ``--phases varied`` rows on main 02b8eea (``--campaigns 0 --swap``: 98 s, load
average 1.4-4.8; ``--no-field --phases varied --missions 60 --duration 60 --campaigns 3``:
161 s, load 3.6-5.0; the same with ``--map-altitude``: 149 s, load 4.5-2.8). The
default-phase sim-load rows and the two blocks under them are earlier runs (load ~7), not
rerun::

    data set       n   median  p90 |e|   in 90%  binom 95%  x floor  met
    target             +-1.50%  <=5.00%  85%-95%             <=1.20
    robot-b       12   -0.04%    1.19%    11/12       8-12     1.07  yyyy
    robot-b swap  12   -0.23%    1.11%    11/12       8-12     1.04  yyyy   (--swap)
    sim-load-0    20   +0.45%    4.70%    16/20      15-20     1.73  yynn   supported 1.74
    sim-load-1    20   -0.24%    2.30%    20/20      15-20     1.79  yynn   supported 1.41
    sim-load-2    20   +0.22%    2.19%    20/20      15-20     2.03  yynn   supported 1.88
                                                                         pooled 56/60
    before the windows outside their fold's support were scored apart:
    sim-load-0    20   +0.45%    4.70%    16/20      15-20     1.73  yynn
    sim-load-1    20   +0.05%    2.50%    20/20      15-20     2.00  yynn
    sim-load-2    20   +0.22%    2.19%    20/20      15-20     2.03  yynn   pooled 56/60
    default phases with --map-altitude (discover given the map: the IMU tilt is checked
    and repaired):
    sim-load-0    20   -0.05%    4.36%    13/20      15-20     1.49  yynn
    sim-load-1    20   -0.08%    1.57%    16/20      15-20     1.44  yynn
    sim-load-2    20   +0.09%    2.03%    19/20      15-20     3.15  yyyn   pooled 48/60
    --phases varied --missions 60 --duration 60 (3 campaigns, each within every energy
    target; seed 0 above 1.2x the floor, below):
    sim-load-0    20   -0.83%    3.47%    19/20      15-20     1.25  yyyn
    sim-load-1    20   -0.29%    1.96%    18/20      15-20     1.02  yyyy
    sim-load-2    20   -0.65%    2.93%    17/20      15-20     1.06  yyyy   pooled 54/60
    the same with --map-altitude (discover given the map: the IMU tilt checked and repaired):
    sim-load-0    20   -1.03%    3.02%    16/20      15-20     0.91  yyny
    sim-load-1    20   -0.38%    1.24%    15/20      15-20     0.92  yyny
    sim-load-2    20   -1.03%    2.63%    15/20      15-20     0.81  yyny   pooled 46/60
    the same with --map-altitude, the twist dead band judged by the energy of paths
    (``twist_noise`` in ``UNIT_REPAIRS``, b3e1e71; 115 s, load 2.0-3.1):
    sim-load-0    20   -0.11%    2.10%    17/20      15-20     0.97  yyyy
    sim-load-1    20   -0.38%    1.24%    15/20      15-20     0.92  yyny
    sim-load-2    20   -0.05%    2.03%    16/20      15-20     0.93  yyny   pooled 48/60
    the same without the map (b3e1e71; 294 s, load 2.6-4.0):
    sim-load-0    20   +0.28%    2.34%    20/20      15-20     1.27  yynn
    sim-load-1    20   -0.29%    1.96%    18/20      15-20     1.02  yyyy
    sim-load-2    20   +0.05%    2.42%    18/20      15-20     1.12  yyyy   pooled 56/60

On the varied campaigns without the map, discover adds ``load_kg*P_base`` (seeds 0 and 2,
then nothing) or ``load_kg*P_base``, ``load_kg*fwd_const`` and ``pos(load_kg - 18)`` (seed
1). Seed 0's 1.25x is the IMU's tilt bias per run (0.3 deg sd, roll and pitch), which logs
without altitude cannot measure (the pose is 2-D; the odometry's horizontal speed moves by
the cosine of the grade, 1e-3 for a 0.3 deg error at 12 deg). Against the simulator's
truth, on the same campaign (seed 0, the same draws of every other sensor):

- ``SensorConfig(imu_bias_deg=0)``, no ``z``: ``load_kg*P_base``, ``speed*(load_kg<9)``,
  8.53 W, 0.98x the floor;
- the logged ``z`` kept (``imu_tilt`` found and repaired): ``load_kg*P_base``,
  ``load_kg_sq*P_copper``, ``load_kg*gait_power``, 7.90 W, 0.91x;
- the true twist in place of the odometry's, no ``z``: ``load_kg*P_base`` only, 11.32 W,
  1.23x (floor 9.24 W: the windows cut from the true twist differ);
- as logged: after ``load_kg*P_base`` (10.88 W) the best candidates lower the held-out RMSE
  by 4-7 % (``motor_temp*lat_tilt_sq`` 10.17 W, run test p 0.14; ``load_kg*speed^2`` 10.44
  W, p 5e-4; ``load_kg_sq*P_copper`` 10.46 W, p 0.004) and the folds choose among
  ``motor_temp`` and ``air_temp_c`` times the sideways-slope terms and ``speed * pos(18 -
  load_kg)`` (choice p 0.15): the per-run offsets of the tilt leave no choice consistent by
  run, and the staircase stops.

With the map every campaign ends below 0.92x, but the intervals then hold 46 of 60 held-out
missions (77 %; the binomial band of 60 is 49-58): each campaign's count lies in its band
of 20, the pooled count does not. The intervals narrow more than the errors do (median
half-width 3.2 / 1.9 / 2.6 % without the map, 1.6 / 1.2 / 1.7 % with it; RMS error 2.2 /
1.2 / 1.5 % against 1.7 / 0.9 / 1.6 %), and what is left is a bias: the normalized errors
``(measured - predicted) / (half-width / 1.645)`` have a mean of +0.90 and an RMS of 1.50
with the map (+0.50 and 1.06 without). The bias follows the twist's dead band
(``twist_noise``), which the repair guard refuses on seeds 0 and 2 by the window power
error (seed 0: 21.60 -> 22.56 W with it, p 0.0009) and keeps on seed 1 (median -0.4 %).
Applied regardless (``discover(..., guard=False)``; the other repairs are kept either way),
seeds 0 and 2 with the map give median -0.11 / -0.05 %, p90 2.10 / 2.03 %, 17/20 and
16/20 in the intervals, 0.97 / 0.93x the floor; without the map +0.28 / +0.05 %, p90 2.34
/ 2.42 %, 20/20 and 18/20, 1.27 / 1.12x. The dead band removes the odometry noise that
``abs()`` and ``pos()`` terms rectify into motion in the training windows; the logged
poses' path is priced without the odometry. The window error rises with the dead band
while the energies of the paths lose their bias. Judged by the energy of a path, as the
repairs of units are (``calibration.prepare.UNIT_REPAIRS`` with ``twist_noise`` added, on
seed 0 without the map), the guard keeps it: median held-out run-energy error 3.94 ->
3.54 %, p_worse 0.09 over 60 runs. The library now does that (``twist_noise`` is in
``UNIT_REPAIRS``; its effect on the other campaigns whose guard refused the dead band,
``docs/diagnosis.md``, is not measured): with the map the rows above (the dead band kept
on every seed, the same numbers as ``guard=False``), 48/60 in the intervals, still below
the band of 60 (49-58). Pooled, the normalized errors have a mean of +0.40 and an RMS of
1.24 (+0.46 / 1.23, +0.54 / 1.15, +0.21 / 1.33 by seed; median half-width 1.6 / 1.2 / 1.6 %).

What is left is the energy the windows never hold. Per held-out mission (seeds 0, 1, 2,
the model discover writes with the map, its error model's sigma for each prediction;
``python benchmarks/field_logs_window_share.py SEED``: the held-out logs prepared as
discover prepares them, the model's per-sample power summed over their windows):

    mean error, z mean, z RMS         seed 0                 seed 1                 seed 2
    whole mission, logged poses    -0.43 % -0.54 1.44    -0.40 % -0.54 1.16    -0.21 % -0.20 1.28
    windows, priced from the pose  -0.13 % -0.16 1.23    -0.11 % -0.14 0.94    -0.06 % -0.06 1.13
    windows, from the odometry     -0.65 % -0.78 1.52    -0.57 % -0.78 1.20    -0.44 % -0.42 1.25

(``z = (predicted - measured) / sigma``, sigma 0.8 / 0.7 / 1.0 % at the median). The
windows hold 95.7 / 95.2 / 95.3 % of a mission's battery energy (median); the rest, the
samples cleaning drops (the speed ramps shorter than ``MIN_STOP_S`` as the gait starts
and stops, samples beyond the consistency bound, windows shorter than 1 s; which of them
holds most of it is not measured), is priced 3-7 % low: -0.29 / -0.29 / -0.15 % of the
mission's energy (sd 0.45 / 0.29 / 0.70 %). (The odometry row's repairs are estimated on
the 20 held-out missions alone.) The error model is calibrated on the held-out runs'
window energies (``calibration.fit.cross_validate``: measured and
predicted over the windows only), so that part of the mission's error is in no score,
and it is mostly a bias, not a spread. Within the windows the pose-priced energies are
calibrated on seed 1 (z RMS 0.94) and a little narrow on seeds 0 and 2 (1.23 and 1.13
over 20: chi-square upper tail p 0.07 and 0.18; pooled over the whole missions in the
table's rows, 1.24 over 60: p 0.005). Calibrating the error model on the pose track
instead of the odometry (each held-out run's window energy priced from ``pose_twist`` by
its fold's coefficients; tried, not kept) does not help: 16 / 11 / 16 of 20 (43/60;
median half-width 1.66 / 0.91 / 1.63 %: seed 1's intervals narrow).
The cause was the whole run: the held-out runs' scores should compare the battery energy
of every sample of the run with the prediction of every sample (done since, below). An
estimate made then, not a measurement (in-sample: the held-out missions' own errors outside their
windows): each interval of the rows above moved by its seed's mean error outside the
windows and widened by its sd in quadrature holds 17 / 19 / 18 of 20, 54/60 (moved only:
15 / 18 / 17). Robot-b with
``--map-altitude`` (``--campaigns 0 --swap``; its logs have no ``z``, the map gives it):
no ``imu_tilt`` finding, the same rows as without the map (11/12 and 11/12, 1.07 / 1.04x).

Held-out runs scored whole (branch whole42, e765da1; the error model's
``scored_on="runs"``): ``prepare_logs`` keeps each run whole beside its windows
(``Windows.whole_runs``: the battery energy of every sample, the samples no window holds,
and with a map each run's logged path), and the cross-validation prices each held-out run
whole by its fold's coefficients (``CrossValidation.whole``): with the map as its logged
poses over the map (``follow.walked_path`` + ``path_energy``, what this benchmark does with
the held-out missions), without it as its windows plus the left-out samples priced from the
pose's twist. The error model is fitted on those. Measured (``--per-mission``; the map rows
174 s, load 5.0-5.3; without the map 243 s, load 5.8-6.8; robot-b 24 s, load 3.5-4.6;
robot-b with ``--map-altitude`` 217 s, load 5.8-6.3)::

    data set       n   median  p90 |e|   in 90%  binom 95%  x floor  met   z mean  z RMS  half-w.
    with --map-altitude (held-out runs priced as their paths over the map):
    sim-load-0    20   -0.11%    2.10%    17/20      15-20     0.97  yyyy   +0.41   1.09   1.77 %
    sim-load-1    20   -0.38%    1.24%    19/20      15-20     0.92  yyyy   +0.46   0.99   1.34 %
    sim-load-2    20   -0.05%    2.03%    16/20      15-20     0.93  yyny   +0.20   1.27   1.71 %
                                                   pooled 52/60 (band 49-58)  +0.36   1.12
    without the map (windows + the left-out samples priced from the pose's twist):
    sim-load-0    20   +0.28%    2.34%    20/20      15-20     1.27  yynn   +0.10   0.79   3.28 %
    sim-load-1    20   -0.29%    1.96%    17/20      15-20     1.02  yyyy   +0.46   1.02   2.17 %
    sim-load-2    20   +0.05%    2.42%    20/20      15-20     1.12  yyny   -0.10   0.64   3.18 %
                                                   pooled 57/60 (band 49-58)  +0.15   0.83
    robot-b       12   -0.04%    1.19%    11/12       8-12     1.07  yyyy   (--campaigns 0 --swap)
    robot-b swap  12   -0.23%    1.11%    12/12       8-12     1.04  yyny
    with --map-altitude (priced as paths):
    robot-b       12   -0.04%    1.19%    12/12       8-12     1.07  yyny   +0.03   0.59   1.55 %
    robot-b swap  12   -0.23%    1.11%    12/12       8-12     1.04  yyny   +0.07   0.89   1.35 %

(``z``: the normalized errors ``(measured - predicted) / (half-width / 1.645)``, now
printed under the table; the rows without the map from the per-mission kJ rounded to 0.1,
so to about 0.1 in ``z``.) The medians, p90s and floors are those of the rows above (the
error model changes no coefficient); only the intervals move. With the map the pooled
count is in its band (was 48/60; z mean +0.40 -> +0.36, RMS 1.24 -> 1.12): what is left is a
bias by load (four of the five 27 kg missions of seed 0 priced 1.5-2.5 % low, three of them
outside), a model error no run-to-run scale can centre. Robot-b's intervals widen a little
(12/12 twice, inside the band; z RMS 0.59 on the first half: a little wide).

With 60 held-out missions per campaign instead of 20 (``--held-out 60``, the same discover
runs; ``--campaigns 3`` 157 s at load 4.2-4.6, ``--seeds 3 4`` 214 s at load 1-3), the
per-campaign counts are tighter (the band of 60 is 49-58) and two campaigns miss a target::

    with --map-altitude --held-out 60:
    sim-load-0    60   +0.13%    1.59%    56/60      49-58     0.97  yyyy   -0.12   0.93   1.74 %
    sim-load-1    60   -0.04%    1.22%    54/60      49-58     0.92  yyyy   +0.08   0.94   1.36 %
    sim-load-2    60   +0.28%    2.46%    47/60      49-58     0.93  yyny   -0.04   1.50   1.73 %
    sim-load-3    60   -0.16%    2.70%    55/60      49-58     1.39  yyyn   +0.22   0.97   2.71 %
    sim-load-4    60   +0.08%    2.01%    56/60      49-58     1.07  yyyy   +0.21   1.02   1.92 %
                                      pooled 268/300 (89 %)

Seeds 0, 1 and 4 meet every target. Seed 2's intervals are centred (z mean -0.04) but too
narrow for its spread (z RMS 1.50): its model holds two load terms (``load_kg*P_base``,
``load_kg_sq*P_copper``) and the missions' errors spread by load more than its held-out
training runs did. Seed 3's discover stops after ``load_kg*P_base`` at 1.39x the floor
(11.59 W against 8.36 W); its intervals are wide enough (z RMS 0.97).

Seed 2 by load (printed under the table): 0 kg 10/15 in (error -1.59 %, z +1.46/1.86), 9 kg
13/15, 18 kg 14/15, 27 kg 10/15 (z -0.21/1.92); 4 missions predicted above every training
run's measured mean power (431 W), 1 of them in (error +2.45 %). Its training runs' cross-validated
whole-run errors show the same ends, weaker: 0 kg -0.48 % (rms 1.30 %), 27 kg -0.56 % (rms
1.22 %), the middle +0.6 % (rms 0.73-1.07 %); the held-out missions err more than the
training runs did (rms 1.57 against 1.10 %; on seeds 0, 1, 3 no more: 1.03 / 1.05, 0.78 /
0.86, 1.62 / 1.82). The same model on two more held-out draws (seeds 2002, 3002) holds 48
and 54 of 60, 0 kg biased -0.9 / -0.7 %: the bench's draw is the odd one at 0 kg. At 27 kg
every draw scatters 1.6-2.1 % (training CV 1.1 %), growing with the mission's power: heavy
missions steep uphill, each range inside the calibration's, their combination beyond every
training run (predicted above the largest cross-validated training run: 8 of the 180
missions of the three draws, 1 in). An error scale that grows toward the ends of the load
range (by the load's position, or one per load), fitted on the cross-validated runs, holds
648-652 of 720 missions (seeds 0-3, three draws each) against 646-650 for today's intervals
widened uniformly to the same mean width and 637 today: it buys what widening buys.

The missions predicted beyond every training run's mean power are what the domain report
now checks (branch power44): the fit records the cross-validated runs' predicted mean power
(``domain.mean_power_w``) and a path beyond it is outside as a whole, its growth not
measured: the interval x 2 (the assumed ``1 + share``, whatever the fitted ``d``) and no
battery decision. Printed per data set as "mean-power check" (``--seeds 0 1 2 3 4``, same
command as above; 377 s, load 4.1-5.1; robot-b ``--campaigns 0 --swap``)::

    data set     runs' power W  in 90 %: with / without / share only  widened  refused (without)
    sim-load-0      170-509          57 / 56 / 56                         2        2 (0)
    sim-load-1      174-477          55 / 54 / 54                         2        2 (0)
    sim-load-2      169-434          48 / 47 / 47                         3        3 (0)
    sim-load-3      175-595          56 / 55 / 55                         3        3 (0)
    sim-load-4      185-658          56 / 56 / 56                         1        1 (0)
    pooled                          272 / 268 / 268 of 300               11       11 (0)
    robot-b         209-266          11 / 11 / 11 of 12                   3        8 (6)
    robot-b swap    206-283          12 / 12 / 12 of 12                   0        6 (6)

Above the runs' power 6 missions, 5 inside (3 without the check); below, 5 missions, 4
inside (2 without). The rest, 263 of 289 (91 %), are as before (the report's measured
growth gives the same counts as the share only on these missions). Robot-b's median stays
-0.04 %; its three widened missions (one above 266 W, two below 209 W) were inside either
way, and six of its intervals are refused without the check too (quantities outside
without a measured growth, ``d`` not fitted). Over three held-out draws of the same five models (900
missions, G's offline tables of issue 28), 9 of 23 missions above and 8 of 14 below were
inside without the check (784 of the other 863); with the interval x 2, 20 and 13.

Priced sample by sample instead (the left-out samples from the pose's twist, each by its
fold's coefficients; what the library does without the map), seed 0 with the map holds
15/20 (tried, not kept where a map is given): the model prices those samples (mostly the
gait starting and stopping at a standstill of the pose) at 236 W against 197 W measured,
a held-out whole-run error of +0.41 % mean (windows alone -0.07 %), while the path over the
map, which the held-out missions are priced by, walks through those stretches differently.
(The cross-validation's window energies, ``CrossValidation.runs``, are trapezoids within
each window and leave out one time step per window, 2.5 % of a 2 s window at 20 Hz; the
whole runs price the windows at their mean power times their duration instead.)

With 12 or 20 missions a calibrated 90 % interval holds all of them in 28 % / 12 % of
samples: the coverage column is to be read against its binomial band. Robot-b's x floor
is against the floor ``discover`` estimates from its logs (white, Gaussian battery noise:
``tests/test_field_logs.py``). Discover adds ``tilt_y_abs`` (a holding cost in proportion
to the sideways load: walking across a slope, the base's copper losses in its square
underprice gentle slopes and overprice steep ones; 6.76 -> 4.44 W) and
``turn_while_walking`` (4.44 -> 3.84 W), then nothing.

Robot-b's per-mission offset was a repair's error. Before, the odometry check measured each
mission's ratio by the net displacement of the integrated twist over the pose's; over a
curved mission of 6-27 minutes the heading error of the integrated twist turns its far end,
and those ratios strayed from the odometry's true scale by up to 4 % (sd 2 %). The repair
then set each mission's speed off by as much: a constant power offset per mission (RMS 2.8
W held out, r = 0.90 with the stray; in-mission error 1.01x the floor), invisible to every
logged quantity, and the final RMSE stood at 1.27x (1.47x swapped). The ratio is now summed
over 10 s chords (``measurements.datacheck.odometry_ratios``). The intervals were too wide
for the same reason: the held-out runs' errors in training carried the offsets, the
energies of logged poses (priced in map metres) did not. Pooled over both halves the
normalized errors ``(measured - predicted) / (half-width / 1.645)`` had an RMS of 0.41
(24/24 inside; chi-square lower tail p 1e-6: too wide); now 1.07 (22/24 inside, p 0.72).

Default-phase campaigns (``MissionConfig()``: 30 x 120 s, sideways 0.15 and backward 0.1
after a stop) against varied-phase ones: a direction of walking on a slope that only one
or two runs hold. Held out by run, the fold without that run predicts it with no data
for it. On seed 1 the backward windows are 16 of 1752, in two missions; the 7 of one of
them hold 31 % of the final squared error (errors -65 to -99 W). On seed 2 with the map,
38 of the 39 sideways-left windows are in one mission and hold 64 % (-95 to -125 W).
They also steer the next step: on seed 1 every fold's training runs choose a different
channel times a backward or sideways term that fits those windows (choice test p 0.37),
and the staircase stops. The forward windows are left at 1.15x the floor within runs,
with a per-run offset (RMS 4.4 W) that follows the load's square (r 0.66: copper losses
in the carried mass, a term discover does not reach) and each run's IMU tilt (r 0.48
with the pitch tilt: field-like logs without altitude cannot check it;
``--map-altitude`` does, 2.00 -> 1.44x on seed 1, but seed 2 then loses its sideways run's fold
to 3.15x). The varied-phase campaigns walk every direction in many runs.

Now ``discover`` scores those windows apart (``WindowData.fold_support``: a window whose
direction of walking, with its grade along the travel, its fold's training runs hold in
fewer than 3 windows from fewer than 2 runs, is an extrapolation; it enters every fit, not
the candidates' scores, tests or choice). The x floor column stays over every window (as
``fit`` reports it); the line under each data set gives the unsupported windows' error
apart and the RMSE of the others ("supported"). Measured (``--no-field --campaigns 3``,
190 s at load 5-6; robot-b with ``--campaigns 0 --swap``: no window outside support, its
rows above unchanged):

    data set     outside support         their RMSE  share of sq. error  supported
    sim-load-0   64 windows of 3 runs      6.65 W          2 %            1.74x
    sim-load-1   18 windows of 4 runs     50.02 W         39 %            1.41x
    sim-load-2   80 windows of 4 runs     19.22 W         18 %            1.88x

On seed 1 that closes the first cause: scored apart, the choice test passes (p 0.005, was
0.37) and the staircase adds ``load_kg*speed^2``: 9.05 -> 8.11 W over every window
(2.00 -> 1.79x), 1.41x over the supported ones. The next step would be a shape of
the load (``load_kg ** 2``, 6.37 -> 5.87 W supported, 1.30x), but its choice fails (p 0.12): the
folds choose among ``pos(18 - load_kg)``, ``pos(load_kg - 18)``, ``pos(load_kg - 9)`` and
``load_kg ** 2``, which four load levels cannot tell apart (three numbers past the linear
part), and the per-run offsets not due to the load (IMU tilt) leave too few runs
consistently better. Seeds 0 and 2 stop after ``load_kg*P_base`` as before (choice p 0.59
and 0.15): on seed 2 the forward windows steeper than 8 deg are off by -25 W on average
at load 0 (one mission's 47 uphill windows are off by -25.5 W) and +20 W at load 27, a
slope range per load that few missions hold, inside the "forward, up" bin. The second
cause's candidate, ``load_kg ** 2`` (the square of a carried mass: copper losses of
supporting it), is now tried on every mass channel; on its own it changes no staircase
(measured on seeds 0-2 before the support rule: 1.73 / 2.00 / 2.03x, no step added). The
1.2x target is not met on these campaigns.

Where the rest lies, against the simulator's truth (``missions_floor_breakdown.py --loads
0 9 18 27 --max-steps 4`` and the same logs' per-window truth; measured, not rerun here):

- the IMU's tilt bias per run (0.3 deg sd, roll and pitch), which logs without altitude
  cannot check, moves the modelled power by 5.16 / 3.93 / 3.02 W RMS per window on seeds
  0 / 1 / 2 (the physics at the measured against the true slope and heading), as much as
  the floor itself on seed 0, and grows with the load (seed 0: 1.5 W at 0 kg, 8.5 W at
  27 kg: the copper losses go with the square of the mass, their slope derivative too).
  With the map (``--map-altitude``, rerun after the support rule: 446 + 166 + 177 s) the
  tilt is repaired: 1.49 / 1.65 / 3.15x over every window, 1.49 / 1.08 / 1.79x over the
  supported ones (the windows outside support, 62 / 18 / 80, are then 8.1 / 56 / 59 W);
- the windows outside support alone cap the ratio over every window: on seed 2 without
  the map, 80 windows at 19-28 W held out leave at best about 1.6x with a perfect fit of
  the others;
- the model's shape of the load: the truth of the steady windows is expressed to 0.7 W by
  the base terms, ``load_kg`` times each of them and ``load_kg ** 2`` (single candidates the
  library has, ``tests/test_missions_discover.py``), to 27 W by the base alone, but the
  staircase adds one term a step and stops after ``load_kg*P_base`` (the steady windows
  at 4.6x their floor of 1.4 W with the tilt repaired). On seed 2 after that step,
  ``load_kg * speed ** 2`` and ``load_kg * speed`` pass their own run test (p 9e-5, 2e-4;
  supported 8.99 -> 7.03 / 6.80 W) while the folds choose by pooled error
  ``load_kg*P_copper`` (6.52 W, p 0.11 by run: a few runs' large errors); choosing by the
  runs' consistency instead (tried, not kept) gives a choice p of 0.045, still above 0.01.
  The whole family at once is no answer either, held out by run (each fold fitting what
  it identifies): on seed 0 with the tilt repaired 5.89 W over the supported windows
  (1.12x) but 91 W over every window, the load times the backward and sideways terms
  extrapolating in the folds without them (55 W / 1.66x supported without the map; seed 2
  without the map 56 W supported); the load times the forward, tilt and gait terms only
  is worse than ``load_kg*P_base`` (seed 0: 11.0 W, 8.6 W with the map).

The choice test over ten deals of the runs into folds (``Thresholds.n_partitions``: each
run's gain averaged over the deals; branch m50). Seed 3 stopped after ``load_kg*P_base``
because its default deal put mission_046 (9 kg on the campaign's only 21 deg slope, 79 % of
the next term's gain) in a fold whose training runs then chose a load hinge: choice p 0.09
there, 0.0003-0.034 on six other deals; averaged over ten, 0.006. Same command as the
``--held-out 60`` table above, ``--seeds 0 1 2 3 4 --per-mission`` (431 s at load 2.3-5.4)::

    sim-load-0    60   +0.13%    1.59%    57/60      49-58     0.97  yyyy   -0.13   0.89   1.76 %
    sim-load-1    60   -0.04%    1.22%    55/60      49-58     0.92  yyyy   +0.09   0.92   1.38 %
    sim-load-2    60   +0.33%    2.52%    46/60      49-58     0.88  yyny   +0.11   1.42   1.73 %
    sim-load-3    60   -0.37%    1.52%    55/60      49-58     1.00  yyyy   +0.20   0.87   1.68 %
    sim-load-4    60   +0.08%    2.01%    56/60      49-58     1.07  yyyy   +0.22   1.02   1.92 %
                                      pooled 269/300 (90 %)

Every seed's discover now ends within 1.2x the TRUE floor (0.88-1.07x). Seed 3 adds
``load_kg_sq*P_copper`` (11.59 -> 8.93 W) and ``load_kg^2`` (8.37 W, 1.00x); seed 2 adds
``load_kg*speed^2`` third (7.42 -> 7.05 W, 0.88x). Seed 2's held-out missions are still
covered 46/60: by load, 0 kg 7/15 in (error -1.89 %, sd 0.98 %), 9 kg 13/15, 18 kg 14/15,
27 kg 12/15; its training runs' held-out windows by load are off by only +0.7 / -0.5 /
-0.6 / +0.7 % (measured - predicted, per-run mean over power). Split against the
simulator's truth (``field_logs_truth_split.py``): the pose pricing and the sensors add
the same at every load in training and held out; the extra is the model on the true
motion, seed 2's load terms (even fitted to the noise-free truth they leave -2.09 % at
0 kg on this draw, the other seeds' terms -0.09 to -0.50 %), on a draw whose 0 kg missions
turn in place and climb more than any of four other draws (there 0 kg is -0.6 to -1.3 %).
With ``--held-out 180`` the five seeds hold 167 / 167 / 146 / 162 / 172 of 180 (band
154-169). Centring or widening each prediction by its load's cross-validated mean error
(tried offline) lifts seed 2 and worsens seeds 0, 1 or 4: not kept. Mean-power check:
269 / 265 / 265 of 300 with it / without / share only, 12 widened, 12 refused (0 without). Robot-b
(``--campaigns 0 --swap``) is unchanged to the digit, and so is
``bench_domain_extrapolation.py`` (91.7 %, beyond 20 deg 89.3 %).

Prints ``uptime`` with the timings (the machine is shared).
"""

from __future__ import annotations

import os

# one BLAS thread: thousands of small least-squares solves (see bench_discover.py)
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import asdict, dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
#: ``shared/field-logs/robot-b`` in the first folder above the repository that has it (a
#: checkout beside ``shared/`` or a work tree further down)
DEFAULT_FIELD_LOGS = next(
    (p / "shared" / "field-logs" / "robot-b" for p in REPO.parents
     if (p / "shared" / "field-logs" / "robot-b").is_dir()),
    REPO.parent / "shared" / "field-logs" / "robot-b",
)  # fmt: skip

#: Issue 28's "Done when": median error within +-1.5 %, p90 |error| within 5 %, nominal
#: 90 % intervals holding 85-95 % of the missions, discover within 1.2x the noise floor.
TARGETS = {"median": 0.015, "p90": 0.05, "coverage": (0.85, 0.95), "floor_ratio": 1.2}


@dataclass
class Mission:
    """One held-out mission: predicted against measured energy."""

    run: str
    measured_j: float
    predicted_j: float
    low_j: float
    high_j: float
    outside_share: float
    duration_s: float
    waypoints: int
    baseline_j: float = float("nan")
    channels: dict[str, Any] = field(default_factory=dict)
    #: the interval of the same domain report without the mean-power check (a domain
    #: that records no runs' power), and the one this bench gave before it used the
    #: report (the share outside only)
    low0_j: float = float("nan")
    high0_j: float = float("nan")
    low_share_j: float = float("nan")
    high_share_j: float = float("nan")
    #: the interval is calibrated, and a battery decision was given (not refused); and
    #: whether it was calibrated without the mean-power check
    calibrated: bool = True
    battery_refused: bool = False
    calibrated0: bool = True

    @property
    def power_w(self) -> float:
        """The predicted mean power, W."""
        return self.predicted_j / self.duration_s

    @property
    def error(self) -> float:
        """Predicted over measured energy, minus 1."""
        return self.predicted_j / self.measured_j - 1.0

    @property
    def covered(self) -> bool:
        """The measured energy lies in the interval."""
        return bool(self.low_j <= self.measured_j <= self.high_j)


@dataclass
class DataSet:
    """One data set's discovery and its held-out missions."""

    name: str
    n_train: int
    added: list[str]
    data_findings: list[str]
    final_rmse_w: float
    floor_w: float
    true_floor_w: float
    missions: list[Mission]
    seconds: float
    model_terms: list[str] = field(default_factory=list)
    failure: str | None = None
    #: the windows outside their fold's support (discover scores them apart) and the
    #: final held-out RMSE over the others
    outside: dict[str, Any] = field(default_factory=dict)
    final_rmse_supported_w: float = float("nan")
    #: the largest mean power (battery energy over duration) of a training run whole
    train_max_power_w: float = float("nan")
    #: the written model's recorded runs' predicted mean power range (None: not recorded)
    power_range_w: list[float] | None = None

    def summary(self) -> dict[str, Any]:
        """Median error, p90 |error|, coverage, floor ratio, and the baseline's."""
        if not self.missions:
            return {"n": 0, "failure": self.failure}
        e = np.array([m.error for m in self.missions])
        b = np.array([m.baseline_j / m.measured_j - 1.0 for m in self.missions])
        cov = np.array([m.covered for m in self.missions])
        floor = self.true_floor_w if np.isfinite(self.true_floor_w) else self.floor_w
        return {
            "n": int(e.size),
            "median": float(np.median(e)),
            "p90_abs": float(np.quantile(np.abs(e), 0.9)),
            "coverage": float(cov.mean()),
            "covered": int(cov.sum()),
            "floor_ratio": self.final_rmse_w / floor,
            "floor_ratio_logs": self.final_rmse_w / self.floor_w,
            "baseline_median": float(np.median(b)),
            "baseline_p90_abs": float(np.quantile(np.abs(b), 0.9)),
            "by_channel": by_channel(self.missions),
            "beyond_train_power": beyond_power(self.missions, self.train_max_power_w),
            "power_check": power_check(self.missions, self.power_range_w),
        }


def _in(m: Mission, lo: float, hi: float) -> bool:
    return bool(lo <= m.measured_j <= hi)


def power_check(missions: list[Mission], rng: list[float] | None) -> dict[str, Any]:
    """What the domain's mean-power check does to these missions' intervals.

    Counts inside the interval with it (``covered``), without it (``covered_without``,
    the same report from a domain that records no runs' power) and as this bench computed
    it before (``covered_share_only``: the share outside only, without the report);
    intervals it widened, battery decisions refused; :func:`_rows` (with and without the
    check) of the missions predicted above and below the recorded range.
    """
    out: dict[str, Any] = {
        "range_w": None if rng is None else [float(rng[0]), float(rng[1])],
        "covered": int(sum(m.covered for m in missions)),
        "covered_without": int(sum(_in(m, m.low0_j, m.high0_j) for m in missions)),
        "covered_share_only": int(sum(_in(m, m.low_share_j, m.high_share_j) for m in missions)),
        "widened": int(
            sum(m.high_j - m.low_j > (m.high0_j - m.low0_j) * (1 + 1e-9) for m in missions)
        ),  # fmt: skip
        "battery_refused": int(sum(m.battery_refused for m in missions)),
        "battery_refused_without": int(sum(not m.calibrated0 for m in missions)),
        "not_calibrated": int(sum(not m.calibrated for m in missions)),
    }
    if rng is not None:
        for side, sel in (("above", lambda m: m.power_w > rng[1]),
                          ("below", lambda m: m.power_w < rng[0])):  # fmt: skip
            ms = [m for m in missions if sel(m)]
            out[side] = {**_rows(ms), "covered_without": int(
                sum(_in(m, m.low0_j, m.high0_j) for m in ms))}  # fmt: skip
    return out


def _rows(missions: list[Mission]) -> dict[str, Any]:
    """Count inside, mean error and normalized errors' mean and RMS of some missions."""
    z = normalized_errors(missions)
    return {
        "n": len(missions),
        "covered": int(sum(m.covered for m in missions)),
        "mean_error": float(np.mean([m.error for m in missions])) if missions else float("nan"),
        "z_mean": float(z.mean()) if z.size else float("nan"),
        "z_rms": float(np.sqrt(np.mean(z**2))) if z.size else float("nan"),
    }


def by_channel(missions: list[Mission], max_values: int = 8) -> dict[str, dict[str, Any]]:
    """Per channel the missions set (at most ``max_values`` values), :func:`_rows` by value.

    Where a channel's misses sit: at the ends of its range (``load_kg`` 0 and 27 kg) an
    error model with one scale for every run may be too narrow while the middle is not.
    """
    names = sorted({k for m in missions for k in m.channels})
    out: dict[str, dict[str, Any]] = {}
    for name in names:
        vals = {m.channels.get(name) for m in missions if name in m.channels}
        num = all(isinstance(v, float) for v in vals)
        vals = sorted(vals) if num else sorted(vals, key=str)
        if len(vals) > max_values:
            continue
        out[name] = {
            f"{v:g}" if isinstance(v, float) else str(v): _rows(
                [m for m in missions if m.channels.get(name) == v]
            )
            for v in vals
        }
    return out


def beyond_power(missions: list[Mission], train_max_w: float) -> dict[str, Any]:
    """:func:`_rows` of the missions predicted above the largest mean power a training run had.

    ``train_max_w``: the training runs' largest battery energy over duration (the run whole).

    Each quantity of such a mission (slope, speed, a channel) may lie in its range while
    their combination (heavy and steep uphill) lies beyond every run the model and its
    error model were fitted on: the domain report, range by range, does not see it.
    """
    if not np.isfinite(train_max_w):
        return {"train_max_power_w": None, **_rows([])}
    far = [m for m in missions if m.predicted_j / m.duration_s > train_max_w]
    return {"train_max_power_w": float(train_max_w), **_rows(far)}


def mission_channels(model: Any, g: pd.DataFrame) -> dict[str, Any]:
    """The mission's value of every channel the model reads (``--set NAME=VALUE``).

    Raises ``ValueError`` naming the channel when the mission has no such column or its
    value changes along the mission (a constant cannot stand for it).
    """
    from energy_planner.energy.channels import channel_kinds

    out: dict[str, Any] = {}
    for name in channel_kinds(model):
        if name not in g.columns:
            raise ValueError(
                f"the model reads channel {name!r}; mission {g['run'].iloc[0]!r} has no such column"
            )
        vals = g[name].dropna().unique()
        if len(vals) != 1:
            raise ValueError(
                f"channel {name!r} takes {len(vals)} values along mission "
                f"{g['run'].iloc[0]!r}: give it as a raster, not a constant"
            )
        v = vals[0]
        out[name] = v if isinstance(v, str) else float(v)
    return out


def mission_energy(terrain: Any, model: Any, g: pd.DataFrame, pose_every: float) -> Mission:
    """Energy of one mission's logged poses with its interval, against its battery energy."""
    from energy_planner.energy import path_energy
    from energy_planner.follow import walked_path
    from energy_planner.measurements import run_energies
    from energy_planner.uncertainty import domain_report, path_trust, predict_interval
    from energy_planner.uncertainty.domain import domain_of, report_against

    g = g.sort_values("t", kind="stable")
    consts = mission_channels(model, g)
    measured = float(run_energies(g)["measured_j"].iloc[0])
    wp = walked_path(g, every_s=pose_every)
    xy = np.column_stack(terrain.to_work(wp.xy[:, 0], wp.xy[:, 1]))
    e = path_energy(terrain, model, xy, yaw=wp.yaw_rad, t=wp.t, constants=consts)
    # as the energy command: the path's domain report (mean power included), then its
    # interval and battery decision (uncertainty.path_trust, what every door calls); the
    # battery (twice the measured energy) only to see whether a decision is given
    dom = domain_report(model, e.table, consts, e.poses, {})
    tr = path_trust(model, e.energy_j, e.duration_s, dom, battery_wh=2 * measured / 3600.0)
    iv = tr.interval
    if iv is None:
        raise ValueError("the model carries no held-out run errors: no interval")
    # the same without the mean-power check, and as this bench did before (share only)
    dom0 = {k: v for k, v in (domain_of(model) or {}).items() if k != "mean_power_w"}
    rep0 = report_against(dom0, e.table, consts, e.poses, {})
    iv0 = predict_interval(model, e.energy_j, duration_s=e.duration_s, domain=rep0)
    ivs = predict_interval(
        model, e.energy_j, outside_share=rep0["outside_share"], duration_s=e.duration_s
    )
    # baseline: every logged pose as the log holds it, repeats and all
    raw = np.column_stack(terrain.to_work(g["x"].to_numpy(float), g["y"].to_numpy(float)))
    t = g["t"].to_numpy(float)
    b = path_energy(terrain, model, raw, yaw=g["yaw"].to_numpy(float), t=t - t[0], constants=consts)
    return Mission(
        run=str(g["run"].iloc[0]),
        measured_j=measured,
        predicted_j=float(e.energy_j),
        low_j=float(iv.low_j),
        high_j=float(iv.high_j),
        outside_share=float(dom["outside_share"]),
        duration_s=float(e.duration_s),
        waypoints=len(wp.t),
        baseline_j=float(b.energy_j),
        channels=consts,
        low0_j=float(iv0.low_j),
        high0_j=float(iv0.high_j),
        low_share_j=float(ivs.low_j),
        high_share_j=float(ivs.high_j),
        calibrated=iv.calibrated,
        battery_refused=tr.battery_refused is not None,
        calibrated0=iv0.calibrated,
    )


def discover_and_write(
    train: Any, out: Path, max_steps: int, terrain: Any = None
) -> tuple[Any, Any]:
    """``ep.discover`` on ``train``; the model written to ``out`` and read back.

    ``terrain``: the map, from which logs without altitude get it (``discover``'s
    ``terrain``: the IMU's tilt is then checked against the pose).
    """
    import energy_planner as ep
    from energy_planner.model import EnergyModel

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = ep.discover(train, max_steps=max_steps, progress=False, terrain=terrain)
    if d.model is None:  # as the command: nothing written, say why
        return d, None
    d.model.save(out)
    return d, EnergyModel.load(out)


def run_dataset(
    name: str,
    train: Any,
    tests: list[pd.DataFrame],
    terrain: Any,
    max_steps: int,
    pose_every: float,
    camp: Any = None,
    map_altitude: bool = False,
) -> DataSet:
    """Discover on ``train``, predict every mission of ``tests``.

    ``map_altitude``: discover is given the map (logs without altitude get it from it).
    """
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        d, model = discover_and_write(
            train, Path(tmp) / f"{name}.json", max_steps, terrain if map_altitude else None
        )
    failure = None
    if model is None:
        failure = "discover wrote no model: " + " ".join(n for n in d.notes if "fit" in n)
    missions = (
        [] if model is None else [mission_energy(terrain, model, g, pose_every) for g in tests]
    )
    rows = d.table()
    true_floor = float("nan") if camp is None else float(camp.noise_floor(d.windows).rmse_w)
    whole = None if d.fit is None or d.fit.heldout is None else d.fit.heldout.whole
    top = float("nan")
    if whole is not None:
        top = float((whole["measured_j"] / whole["duration_s"]).max())
    return DataSet(
        failure=failure,
        name=name,
        n_train=int(pd.unique(np.asarray(d.data.runs)).size),
        added=[r["name"] for r in rows[1:]],
        data_findings=[
            f"{f.name}{'' if f.repaired else ' (not repaired)'}"
            for f in d.data_findings
            if f.finding
        ],
        final_rmse_w=float(rows[-1]["heldout_rmse_w"]),
        floor_w=float(d.floor.rmse_w) if d.floor is not None else float("nan"),
        true_floor_w=true_floor,
        missions=missions,
        seconds=time.perf_counter() - t0,
        model_terms=[] if model is None else list(model.term_names),
        outside=dict(rows[-1].get("outside_support") or {}),
        final_rmse_supported_w=float(rows[-1].get("supported_rmse_w", float("nan"))),
        train_max_power_w=top,
        power_range_w=None if model is None else domain_power(model),
    )


def domain_power(model: Any) -> list[float] | None:
    """The runs' predicted mean power range the model's domain records, or None."""
    from energy_planner.uncertainty.domain import domain_of

    rng = (domain_of(model) or {}).get("mean_power_w")
    return None if not rng else [float(rng[0]), float(rng[1])]


def binomial_band(n: int, level: float = 0.9, mass: float = 0.95) -> tuple[int, int]:
    """The central ``mass`` band of how many of ``n`` calibrated intervals hold their truth.

    A count outside it says the intervals of nominal ``level`` are miscalibrated.

    With 12 missions a calibrated 90 % interval holds all 12 in 28 % of samples and 11 in
    38 %: the 85-95 % target is then met by exactly 11 of 12, which is chance.
    """
    from scipy.stats import binom

    a = (1.0 - mass) / 2.0
    return int(binom.ppf(a, n, level)), int(binom.isf(a, n, level))


def field_dataset(
    root: Path, max_steps: int, pose_every: float, swap: bool = False, map_altitude: bool = False
) -> DataSet:
    """``robot-b`` (or its fixture subset): discover on ``train/``, predict ``test/``.

    ``swap``: the other way round (discover on ``test/``, predict ``train/``): a second
    sample of held-out missions from the same logs.
    """
    import energy_planner as ep

    missing = [p for p in ("train", "test", "ridge.tif") if not (root / p).exists()]
    if missing:
        raise SystemExit(
            f"error: --field-logs {root}: no {', '.join(missing)} there; expected "
            "train/, test/ and ridge.tif (or pass --no-field)"
        )
    fit_on, held = ("test", "train") if swap else ("train", "test")
    tests = [pd.read_parquet(f) for f in sorted((root / held).glob("*.parquet"))]
    terrain = ep.open_terrain(root / "ridge.tif")
    name = root.name + (" swap" if swap else "")
    return run_dataset(
        name, root / fit_on, tests, terrain, max_steps, pose_every, map_altitude=map_altitude
    )


def sim_dataset(seed: int, args: argparse.Namespace) -> DataSet:
    """Missions simulated with the ``load`` effect: discover on ``seed``, predict another."""
    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem

    make = MissionConfig.varied if args.phases == "varied" else MissionConfig
    cfg = make(
        missions=args.missions,
        duration_s=args.duration,
        rate_hz=args.rate,
        loads_kg=tuple(args.loads),
    )
    terrain = synthetic_dem(seed)
    camp = simulate_missions(seed=seed, effects=("load",), config=cfg, terrain=terrain)
    held = simulate_missions(
        seed=seed + 1000,
        effects=("load",),
        config=cfg.replace(missions=args.held_out),
        terrain=terrain,
    )
    logs = held.logs.drop(columns="z")
    tests = [g for _, g in logs.groupby("run", sort=True)]
    return run_dataset(
        f"sim-load-{seed}",
        camp.logs.drop(columns="z"),
        tests,
        terrain,
        args.max_steps,
        args.pose_every,
        camp=camp,
        map_altitude=args.map_altitude,
    )


def normalized_errors(missions: list[Mission]) -> np.ndarray:
    """``(measured - predicted) / (half-width / 1.645)`` of each mission's 90 % interval.

    A calibrated, normal error scale gives a mean near 0 and an RMS near 1.
    """
    return np.array(
        [
            (m.measured_j - m.predicted_j) / ((m.high_j - m.low_j) / 2 / 1.645)
            for m in missions
            if m.high_j > m.low_j
        ]
    )


def floor_of(s: DataSet) -> float:
    """The floor a data set's ratio is against: the TRUE one when known, else the logs'."""
    return s.true_floor_w if np.isfinite(s.true_floor_w) else s.floor_w


def _pct(v: float, signed: bool = False) -> str:
    return f"{100 * v:+.2f}%" if signed else f"{100 * v:.2f}%"


def _ok(s: dict[str, Any]) -> str:
    lo, hi = TARGETS["coverage"]
    checks = [
        abs(s["median"]) <= TARGETS["median"],
        s["p90_abs"] <= TARGETS["p90"],
        lo <= s["coverage"] <= hi,
        s["floor_ratio"] <= TARGETS["floor_ratio"],
    ]
    return "".join("y" if c else "n" for c in checks)


def print_tables(
    sets: list[DataSet], what: str, command: str, uptime: str, per_mission: bool
) -> None:
    """The summary table (targets beside), the per-mission tables and the discoveries."""
    lo, hi = TARGETS["coverage"]
    print(f"\nenergy of held-out missions' logged poses against their battery energy ({what})")
    print(
        f"{'data set':<14}{'n':>4}{'median':>9}{'p90 |e|':>9}{'in 90%':>10}{'binom 95%':>10}"
        f"{'RMSE W':>8}{'floor W':>8}{'x floor':>8}  {'met':<5}"
        f"{'| baseline: median':>19}{'p90 |e|':>9}"
    )
    print(
        f"{'target':<14}{'':>4}{'+-1.50%':>9}{'<=5.00%':>9}{f'{lo:.0%}-{hi:.0%}':>10}{'':>10}"
        f"{'':>8}{'':>8}{'<=1.20':>8}  {'':<5}{'| every logged pose':>19}"
    )
    for s in sets:
        m = s.summary()
        floor = s.true_floor_w if np.isfinite(s.true_floor_w) else s.floor_w
        if not m["n"]:
            print(
                f"{s.name:<14}{'-':>4}  no model written (below); RMSE {s.final_rmse_w:.2f} W, "
                f"{s.final_rmse_w / floor:.2f}x the floor"
            )
            continue
        band = "{}-{}".format(*binomial_band(m["n"]))
        print(
            f"{s.name:<14}{m['n']:>4}{_pct(m['median'], True):>9}{_pct(m['p90_abs']):>9}"
            f"{str(m['covered']) + '/' + str(m['n']):>10}{band:>10}"
            f"{s.final_rmse_w:>8.2f}{floor:>8.2f}"
            f"{m['floor_ratio']:>8.2f}  {_ok(m):<5}"
            f"{_pct(m['baseline_median'], True):>19}{_pct(m['baseline_p90_abs']):>9}"
        )
    sims = [s for s in sets if s.name.startswith("sim-")]
    pool = [m for s in sims for m in s.missions]
    if pool:
        e = np.array([m.error for m in pool])
        cov = np.array([m.covered for m in pool])
        n_met = sum(s.summary()["n"] > 0 and _ok(s.summary()) == "yyyy" for s in sims)
        print(
            f"{'sim pooled':<14}{e.size:>4}{_pct(float(np.median(e)), True):>9}"
            f"{_pct(float(np.quantile(np.abs(e), 0.9))):>9}"
            f"{str(int(cov.sum())) + '/' + str(e.size):>10}   ({cov.mean():.0%} in the intervals); "
            f"simulated campaigns meeting every target: {n_met}/{len(sims)}"
        )
    for s in sets:
        z = normalized_errors(s.missions)
        if z.size:
            hw = np.median([(m.high_j - m.low_j) / 2 / m.predicted_j for m in s.missions])
            print(
                f"{s.name:<14} normalized errors (measured - predicted) / (half-width / "
                f"1.645): mean {z.mean():+.2f}, RMS {np.sqrt(np.mean(z**2)):.2f}; median "
                f"half-width {100 * hw:.2f} %"
            )
    if pool:
        z = normalized_errors(pool)
        print(f"{'sim pooled':<14} normalized errors: mean {z.mean():+.2f}, RMS "
              f"{np.sqrt(np.mean(z**2)):.2f}")  # fmt: skip
    for s in sets:
        if not s.missions:
            continue
        for name, by in by_channel(s.missions).items():
            print(f"{s.name:<14} by {name}: " + "; ".join(
                f"{v}: {r['covered']}/{r['n']} in, error {_pct(r['mean_error'], True)}, z "
                f"{r['z_mean']:+.2f}/{r['z_rms']:.2f}" for v, r in by.items()))  # fmt: skip
        far = beyond_power(s.missions, s.train_max_power_w)
        if far["n"]:
            print(
                f"{s.name:<14} predicted mean power above every training run's measured "
                f"({far['train_max_power_w']:.0f} W): {far['covered']}/{far['n']} in, error "
                f"{_pct(far['mean_error'], True)}, z {far['z_mean']:+.2f}/{far['z_rms']:.2f}"
            )
    for s in sets:
        if not s.missions:
            continue
        pc = power_check(s.missions, s.power_range_w)
        rng = "not recorded" if pc["range_w"] is None else "{:.0f}-{:.0f} W".format(
            *pc["range_w"])  # fmt: skip
        line = (f"{s.name:<14} mean-power check (runs' predicted power {rng}): "
                f"{pc['covered']}/{len(s.missions)} in with it, {pc['covered_without']} "
                f"without, {pc['covered_share_only']} by the share only; "
                f"{pc['widened']} widened, {pc['battery_refused']} battery decisions "
                f"refused ({pc['battery_refused_without']} without)")  # fmt: skip
        for side in ("above", "below"):
            r = pc.get(side)
            if r and r["n"]:
                line += (f"; {side} {r['n']}: {r['covered']} in ({r['covered_without']} "
                         f"without), error {_pct(r['mean_error'], True)}")  # fmt: skip
        print(line)
    print(
        "met: y/n for median, p90, coverage, x floor (floor: the simulator's TRUE floor for "
        "simulated sets, the floor discover estimates from the logs for field logs); binom "
        "95%: the counts a calibrated 90 % interval gives in 95 % of samples of that size; "
        "by CHANNEL: per value, missions in their interval, mean error, normalized errors' "
        "mean/RMS"
    )
    for s in sets:
        floors = f"floor from the logs {s.floor_w:.2f} W"
        if np.isfinite(s.true_floor_w):
            floors += f", TRUE floor {s.true_floor_w:.2f} W"
        print(
            f"\n{s.name}: discover added {'; '.join(s.added) or '(nothing)'}; data findings: "
            f"{', '.join(s.data_findings) or 'none'}; final held-out RMSE "
            f"{s.final_rmse_w:.2f} W ({floors}); written model: {len(s.model_terms)} terms "
            f"({s.seconds:.0f} s)"
        )
        if s.outside.get("n_windows"):
            o = s.outside
            print(
                f"  outside their fold's support (a direction of walking no other fold's runs "
                f"hold; scored apart): {o['n_windows']} windows of {o['n_runs']} run(s), "
                f"{o['rmse_w']:.2f} W, {o['share_sq_error']:.0%} of the squared error; the "
                f"others: {s.final_rmse_supported_w:.2f} W "
                f"({s.final_rmse_supported_w / floor_of(s):.2f}x)"
            )
        if s.failure:
            print(f"  {s.failure}")
        if not per_mission:
            continue
        print(
            f"  {'mission':<13}{'channels':<16}{'measured kJ':>12}{'predicted kJ':>13}"
            f"{'error':>8}{'90% interval kJ':>20}{'in':>4}{'outside':>8}{'baseline':>10}"
        )
        for m in s.missions:
            ch = (
                ",".join(
                    f"{k}={v:g}" if not isinstance(v, str) else f"{k}={v}"
                    for k, v in m.channels.items()
                )
                or "-"
            )
            print(
                f"  {m.run:<13}{ch[:15]:<16}{m.measured_j / 1e3:>12.1f}"
                f"{m.predicted_j / 1e3:>13.1f}{_pct(m.error, True):>8}"
                f"{f'[{m.low_j / 1e3:.1f} .. {m.high_j / 1e3:.1f}]':>20}"
                f"{'y' if m.covered else 'n':>4}{m.outside_share:>8.0%}"
                f"{_pct(m.baseline_j / m.measured_j - 1, True):>10}"
            )
    print(f"\ncommand: {command}\n{uptime}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--field-logs",
        type=Path,
        default=DEFAULT_FIELD_LOGS,
        help="robot-b: a folder with train/, test/ and ridge.tif",
    )
    ap.add_argument("--no-field", action="store_true", help="skip the field logs")
    ap.add_argument(
        "--swap",
        action="store_true",
        help="also discover on the field logs' test/ and predict train/ (twice the missions)",
    )
    ap.add_argument("--campaigns", type=int, default=3, help="simulated campaigns (seeds 0..N-1)")
    ap.add_argument("--seeds", type=int, nargs="*", default=None, help="instead of --campaigns")
    ap.add_argument("--missions", type=int, default=30, help="simulated missions for discover")
    ap.add_argument("--held-out", type=int, default=20, help="simulated held-out missions")
    ap.add_argument("--duration", type=float, default=120.0, help="s per simulated mission")
    ap.add_argument("--rate", type=float, default=20.0, help="simulated log rate, Hz")
    ap.add_argument(
        "--loads",
        type=float,
        nargs="+",
        default=[0.0, 9.0, 18.0, 27.0],
        help="loads the simulated missions carry, kg",
    )
    ap.add_argument("--phases", choices=("default", "varied"), default="default")
    ap.add_argument("--max-steps", type=int, default=4)
    ap.add_argument(
        "--pose-every",
        type=float,
        default=0.5,
        help="one logged pose every this many s (follow.walked_path)",
    )
    ap.add_argument(
        "--map-altitude",
        action="store_true",
        help="give discover the map: logs without altitude get it, the IMU tilt is checked",
    )
    ap.add_argument("--per-mission", action="store_true", help="a row per mission too")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--save", type=Path, default=None, help="also write the JSON to this file")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    sets: list[DataSet] = []
    if not args.no_field:
        for swap in (False, True) if args.swap else (False,):
            sets.append(
                field_dataset(
                    args.field_logs, args.max_steps, args.pose_every, swap,
                    args.map_altitude,
                )
            )  # fmt: skip
            print(f"  {sets[-1].name}: {sets[-1].seconds:.0f} s", file=sys.stderr)
    seeds = list(range(args.campaigns)) if args.seeds is None else args.seeds
    for seed in seeds:
        sets.append(sim_dataset(seed, args))
        print(f"  {sets[-1].name}: {sets[-1].seconds:.0f} s", file=sys.stderr)
    elapsed = time.perf_counter() - t0
    uptime = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    command = "python benchmarks/bench_field_logs.py " + " ".join(
        sys.argv[1:] if argv is None else argv
    )
    what = (
        f"simulated: {args.missions} + {args.held_out} held-out missions x "
        f"{args.duration:g} s at {args.rate:g} Hz, {args.phases} phases, loads "
        f"{'/'.join(f'{v:g}' for v in args.loads)} kg, no z (discover "
        f"{'with' if args.map_altitude else 'without'} the map's altitude); poses every "
        f"{args.pose_every:g} s"
    )
    doc = {
        "config": what,
        "command": command,
        "targets": TARGETS,
        "data_sets": [asdict(s) | {"summary": s.summary()} for s in sets],
        "elapsed_s": elapsed,
        "uptime": uptime,
    }
    for d, s in zip(doc["data_sets"], sets, strict=True):
        for dm, m in zip(d["missions"], s.missions, strict=True):
            dm.update(error=m.error, covered=m.covered)
    if args.save is not None:
        from energy_planner.io import write_json

        write_json(args.save, doc, default=float)
    if args.json:
        print(json.dumps(doc, indent=2, default=float))
        return 0
    print_tables(sets, what, command, f"{elapsed:.0f} s in all; {uptime}", args.per_mission)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
