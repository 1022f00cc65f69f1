# Convergence of mc (RMSE), qmc (|error|, unscrambled Sobol) and rqmc (RMSE)
# on the smooth Genz families at one d, with reference slopes N^-1/2,
# N^-1 and N^-3/2 drawn through each method's first point.
# Usage: gnuplot -e "csv='build/bench/integrate-conv.csv'; d=4; \
#          png='build/bench/integrate-conv-d4.png'" bench/integrate_conv.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 1500,500 noenhanced font 'sans,9' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 1500,500 noenhanced font ',9'
    set output png
}
set datafile separator ','
set logscale xy
set format y '%.0e'
set grid
set key bottom left font ',8'
set xlabel 'N'
set ylabel 'error'
families = 'oscillatory product-peak gaussian'
sel(m, f) = sprintf("< awk -F, '$1 == \"%s\" && $2 == \"genz-%s\" && $3 == %d && $5 > 0' %s", m, f, d, csv)
first(m, f) = sprintf("< awk -F, '$1 == \"%s\" && $2 == \"genz-%s\" && $3 == %d && $4 == 256' %s", m, f, d, csv)
set multiplot layout 1,3 title sprintf('Convergence at d = %d (Genz FIXED, seed 1)', d)
do for [f in families] {
    stats first('mc', f) using 5 nooutput name 'MC'
    stats first('qmc', f) using 5 nooutput name 'QMC'
    stats first('rqmc', f) using 5 nooutput name 'RQMC'
    set title f
    plot sel('mc', f) using 4:5 with linespoints lw 2 pt 7 title 'mc (RMSE)', \
         sel('qmc', f) using 4:5 with linespoints lw 2 pt 5 title 'qmc (|error|)', \
         sel('rqmc', f) using 4:5 with linespoints lw 2 pt 9 title 'rqmc (RMSE)', \
         [256:*] MC_max * (x / 256) ** -0.5 dt 2 lc 'gray40' title 'N^-1/2', \
         [256:*] QMC_max * (x / 256) ** -1 dt 3 lc 'gray40' title 'N^-1', \
         [256:*] RQMC_max * (x / 256) ** -1.5 dt 4 lc 'gray40' title 'N^-3/2'
}
unset multiplot
