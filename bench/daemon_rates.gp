# Chart of bench_daemon.sh's small-request rates: Redis PING, qmcd PING and
# qmcd 1-point POINTS, 50 connections, by transport and pipelining.
# Usage: gnuplot -e "dat='build/bench/daemon-rates.dat'; png='build/bench/daemon-rates.png'" \
#          bench/daemon_rates.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 900,560 noenhanced font 'sans,11' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 900,560 noenhanced
    set output png
}
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set logscale y
set yrange [1000:*]
set ylabel 'requests / s (log scale)'
set xlabel 'transport - pipeline depth'
set title 'Small requests, 50 connections: qmcd vs Redis (same run)'
set key top left
set grid ytics
plot dat using 2:xtic(1) title columnheader(2), \
     '' using 3 title columnheader(3), \
     '' using 4 title columnheader(4)
