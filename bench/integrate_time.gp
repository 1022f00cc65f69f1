# Error against wall time, one panel per Genz family, for one dimension d:
# every method of bench_integrate's budgeted runs, one point per budget:
# the geometric mean of |error| / int |f| over the integrand draws and the
# mean wall time (successful runs only; a budget with a failed draw is
# left out; each line joins a method's budgets 1e4 .. 1e7).
# Usage: gnuplot -e "csv='build/bench/integrate-runs.csv'; d=10; \
#          png='build/bench/integrate-time-d10.png'" bench/integrate_time.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 1500,900 noenhanced font 'sans,9' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 1500,900 noenhanced font ',9'
    set output png
}
set datafile separator ','
set logscale xy
set format x '%.0e'
set format y '%.0e'
set grid
set key top right font ',8'
families = 'oscillatory product-peak corner-peak gaussian continuous discontinuous'
peers = 'gsl-plain gsl-miser gsl-vegas gsl-sobol hcubature pcubature'
ours = 'auto rqmc cubature'
# runs.csv columns: 1 method, 2 family, 3 dims, 4 draw, 5 budget, 7 seconds,
# 8 abs_error, 12 abs_integral, 14 outcome.  Errors are floored at 1e-16
# of int |f| (an exact hit has no logarithm).
sel(m, f) = sprintf("< awk -F, '$1 == \"%s\" && $2 == \"genz-%s\" && $3 == %d { all[$5]++ } $1 == \"%s\" && $2 == \"genz-%s\" && $3 == %d && $14 == \"ok\" { e = $8 > 1e-16 * $12 ? $8 : 1e-16 * $12; ok[$5]++; t[$5] += $7; l[$5] += log(e / $12) } END { for (b in ok) if (ok[b] == all[b]) print b, t[b] / ok[b], exp(l[b] / ok[b]) }' %s | sort -g", m, f, d, m, f, d, csv)
# The methods of `want` with at least one plottable run here, in order (so
# that a method that crashed or was refused at this d draws no empty line
# and gnuplot prints no warning).
present(want, f) = system(sprintf("awk -F, -v want='%s' 'BEGIN { n = split(want, w, \" \") } $2 == \"genz-%s\" && $3 == %d && $14 == \"ok\" { ok[$1] = 1 } END { for (i = 1; i <= n; i++) if (w[i] in ok) printf \"%%s \", w[i] }' %s", want, f, d, csv))
set multiplot layout 2,3 title sprintf('|error| / int |f| (geometric mean over the draws) vs mean wall seconds, d = %d (same run, one child process per run; dashed: peers, thick: ours)', d)
do for [f in families] {
    set title f
    set xlabel 'seconds'
    set ylabel '|error| / int |f|'
    p = present(peers, f)
    o = present(ours, f)
    set datafile separator whitespace
    plot for [m in p] sel(m, f) using 2:3 with linespoints lw 1 dt 2 pt 6 title m, \
         for [m in o] sel(m, f) using 2:3 with linespoints lw 3 dt 1 pt 7 title m
}
unset multiplot
