# Chart of bench_seq's L2-resident rates: million coordinates/s by dims.
# Usage: gnuplot -e "csv='build/bench/seq.csv'; png='build/bench/seq-rates.png'" bench/seq_rates.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 900,560 noenhanced font 'sans,11' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 900,560 noenhanced
    set output png
}
set datafile separator ','
set logscale xy
set xlabel 'dimensions'
set ylabel 'million coordinates per CPU second (f64, 512 KiB buffer)'
set title 'Batch fill speed: qmcd vs GSL vs memset (same run)'
set key outside right
set xtics (2, 8, 32, 256)
gens = 'memset sobol sobol-owen fast-owen sobol-shift halton gsl-sobol gsl-halton'
plot for [g in gens] sprintf("< awk -F, '$1 == \"l2\" && $3 == \"%s\"' %s", g, csv) \
     using 2:($4 / 1e6) with linespoints lw 2 title g
