#!/bin/sh
# Extra CI stages beyond `make check`: a quick reproduction and figure check.
set -e
make reproduce QUICK=1 OUT=build/ci-results
