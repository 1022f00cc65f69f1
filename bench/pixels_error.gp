# Pictures of bench_pixels' blue-noise measure: zsobol's and padded-sobol's
# error images side by side (seed 0; every pixel estimates a disk's area
# from its own samples), their mean power spectra over 16 seeds, and their
# radially averaged spectra, with the low band the blue-noise target reads
# shaded.  (The sobol sampler's error is a structured pattern whose rings
# swing over 25 decades; its numbers are in pixels-radial.csv.)
# Usage: gnuplot -e "dir='build/bench'; png='build/bench/pixels-error.png'" bench/pixels_error.gp
# svg='FILE' (instead of png='FILE') writes the chart as SVG; make bench
# writes both, side by side.
if (exists("svg")) {
    set terminal svg size 1500,900 noenhanced font 'sans,11' background '#ffffff'
    set output svg
} else {
    set terminal pngcairo size 1500,900 noenhanced font 'sans,10'
    set output png
}
set datafile separator ','
err = dir.'/pixels-error.csv'
pow = dir.'/pixels-power.csv'
rad = dir.'/pixels-radial.csv'
low = dir.'/pixels-lowband.csv'
pick(file, s) = sprintf("< awk -F, 'NR > 1 && $1 == \"%s\"' %s", s, file)

# One colour scale for both error images, symmetric about 0 and clipped at
# 3 standard deviations of padded-sobol's error (a few outliers would
# otherwise wash everything out), and one for both spectra, so the two
# samplers are compared on equal terms.
stats pick(err, 'padded-sobol') using 5 nooutput
emax = 3 * STATS_stddev
stats pick(rad, 'padded-sobol') using 3 nooutput
white = STATS_mean
stats rad using 2 every ::1 nooutput
kmax = STATS_max
stats err using 2 every ::1 nooutput
spp = int(STATS_max)
stats sprintf("< awk -F, '$1 == %d && $2 == 0 && $3 == \"zsobol\"' %s", spp, low) using 5 nooutput
ratio = STATS_max
spp_note = sprintf('spp %d, frame 0; low band: zsobol %.2fx padded-sobol', spp, ratio)

set multiplot title sprintf('Pixel samplers: error of a disk-area estimate per pixel (%s) - blue noise vs white noise', spp_note)

# ---- error images (top row, left two columns) ----------------------------
set size square 0.3, 0.48
unset key
set tics out nomirror
set xrange [-0.5:*] noextend
set yrange [-0.5:*] noextend
set palette defined (-1 '#2166ac', 0 '#f7f7f7', 1 '#b2182b')
set cbrange [-emax:emax]
set cblabel 'estimate - exact'
do for [i = 1:2] {
    s = word('zsobol padded-sobol', i)
    set origin (i - 1) * 0.3, 0.5
    set title sprintf('%s: error image (seed 0)', s)
    plot pick(err, s) using 3:4:5 with image
}

# ---- 2D mean power spectra (bottom row) ------------------------------------
set logscale cb
set cbrange [white / 100:white * 4]
set palette defined (0 '#000004', 1 '#3b0f70', 2 '#8c2981', 3 '#de4968', 4 '#fe9f6d', 5 '#fcfdbf')
set cblabel 'power (mean of 16 seeds)'
set format cb '%.0e'
set xrange [*:*]
set yrange [*:*]
set xlabel 'kx (cycles per image)'
set ylabel 'ky'
do for [i = 1:2] {
    s = word('zsobol padded-sobol', i)
    set origin (i - 1) * 0.3, 0.0
    set title sprintf('%s: power spectrum of the error', s)
    plot pick(pow, s) using 2:3:4 with image
}
unset logscale cb
unset format
unset xlabel
unset ylabel

# ---- radial spectra (right, full height) -----------------------------------
set size nosquare 0.4, 0.92
set origin 0.6, 0.02
set title "Radially averaged power spectrum (mean of 16 seeds), relative to\npadded-sobol's mean over all rings (the white level)"
set key bottom right
set logscale y
set xrange [0:kmax]
set yrange [0.01:2]
set format y '%g'
set xlabel '|k| (ring, cycles per image)'
set ylabel sprintf('ring power / white level (%.3g)', white) offset 1, 0
set grid
lowk = kmax / 8
set object 1 rect from 0.5, graph 0 to lowk + 0.5, graph 1 fc rgb '#dddddd' fs solid 0.5 noborder behind
set label 1 'low band' at lowk / 2.0 + 0.5, graph 0.03 center
plot for [s in 'zsobol padded-sobol'] pick(rad, s) using 2:($3 / white) with linespoints lw 2 pt 7 ps 0.5 title s
unset multiplot
