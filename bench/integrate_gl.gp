# Gauss-Legendre in 1D: |error| against the number of nodes n on exp(x) and
# cos(x) over [0,1] (exact zeros are drawn at 1e-17).
# Usage: gnuplot -e "csv='build/bench/integrate-gl.csv'; \
#          png='build/bench/integrate-gl.png'" bench/integrate_gl.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 800,500 noenhanced font 'sans,11' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 800,500 noenhanced
    set output png
}
set datafile separator ','
set logscale y
set format y '%.0e'
set yrange [1e-17:1]
set grid
set xlabel 'nodes n'
set ylabel '|error|'
set title 'Gauss-Legendre on [0,1]: exponential convergence to rounding'
sel(f) = sprintf("< awk -F, '$1 == \"%s\"' %s", f, csv)
plot for [f in 'exp cos'] sel(f) using 2:($3 > 0 ? $3 : 1e-17) with linespoints lw 2 title f
