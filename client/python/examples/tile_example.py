#!/usr/bin/python3
"""tile_example.py - a renderer's pixel samples from qmcd: one 64x64 tile
of a 1920x1080 frame sampled by zsobol (pbrt-v4's ZSobolSampler, bit for
bit) at 16 samples per pixel, 8 values per sample.

    QMC_ENDPOINT=unix:/run/qmcd/qmcd.sock python3 tile_example.py

tile[y, x, s, d] is value d of sample s of pixel (x0 + x, y0 + y): the
bytes `qmc pixels` writes for the same tile, as a (64, 64, 16, 8) array.
"""
import qmcd

with qmcd.connect() as client:
    tile = client.pixels("zsobol", resolution=(1920, 1080), spp=16, dims=8,
                         tile=(0, 0, 64, 64))
    print("tile       %s of %s" % (tile.shape, tile.dtype))
    print("pixel 5,9  sample 0: %s" % tile[9, 5, 0, :4].tolist())
    # Node k of K renders samples [k*16/K, (k+1)*16/K) of every pixel:
    node = client.pixels("zsobol", (1920, 1080), 16, 8, tile=(0, 0, 64, 64), samples=(4, 4))
    print("node 2/4   the same values: %s" % bool((node == tile[:, :, 4:8]).all()))
    print("mean       %s" % [round(float(m), 4) for m in tile.mean(axis=(0, 1, 2))])
