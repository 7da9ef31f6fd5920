#!/bin/sh
# The issue-31 ghost geometry check for the 10 brightest ghosts of the double Gauss with a small
# bright light 10 degrees off axis: each ghost rendered alone ("string flareghosts"), its ghost
# layer's centroid and RMS radius against `lens ghosts --angle 10` and the beam traced from the
# light, within a pixel (0.54 mm on a 64 x 48 film of 43.3 mm diagonal). Takes a few minutes on
# 2 cores. Usage: bench/flare_ghost_spots.sh [BUILD_DIR]
set -e
build=${1:-build}
LENSIM_FLARE_TEN_GHOSTS=1 "$build/tests/render_flare_test" \
  --gtest_filter='FlareRender.EachGhostLiesWhereLensGhostsAngleSaysWithinAPixel'
