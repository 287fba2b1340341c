# poolreps — see README.md. `make reproduce` and `make check` are the two entry points.
CC      ?= cc
CFLAGS  ?= -O2 -g
PREFIX  ?= /usr/local
PYTHON  ?= $(shell for p in /usr/bin/python3 python3; do $$p -c 'import matplotlib' 2>/dev/null && { command -v $$p; break; }; done)
OUT     ?= results
# parallel jobs of the build that `make reproduce` starts and of pytest in `make check`
JOBS    ?= $(shell nproc 2>/dev/null || echo 2)

VERSION := $(shell git describe --always --dirty --tags 2>/dev/null || cat VERSION 2>/dev/null || echo 0.1.0)
WARN    := -std=c11 -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes
DEFS    := -D_POSIX_C_SOURCE=200809L -DHAVE_INLINE -DPR_VERSION_STR='"$(VERSION)"'
PKGS    := gsl
# FUZZ=1: the library instrumented for libFuzzer (clang), for the harnesses
# of tests/fuzz (target fuzz-bin; `make fuzz` runs them)
FUZZ_CC ?= clang
ifeq ($(FUZZ),1)
  override CC := $(FUZZ_CC)
  CFLAGS += -O1 -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
  LDFLAGS += -fsanitize=address,undefined
  BUILD := build/fuzz
else ifeq ($(COV),1)
  # COV=1: line coverage (gcov, part of gcc) of src/ over whatever runs:
  # `make check COV=1` runs the whole suite, pytest included, on these
  # objects and prints scripts/coverage.py's table (docs/testing.md)
  CFLAGS += -O0 --coverage
  LDFLAGS += --coverage
  BUILD := build/cov
else ifeq ($(SAN),1)
  CFLAGS += -O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
  LDFLAGS += -fsanitize=address,undefined
  BUILD := build/san
else
  BUILD := build/rel
endif
ALL_CFLAGS = $(WARN) $(DEFS) -Iinclude -Isrc/private -Isrc $(shell pkg-config --cflags $(PKGS) 2>/dev/null) $(CFLAGS) -MMD -MP
LIBS    := $(shell pkg-config --libs $(PKGS) 2>/dev/null) -lglpk -lcsv -linih -lnlopt -lpthread -lm

LIB_SRC := $(wildcard src/*.c)
LIB_OBJ := $(LIB_SRC:src/%.c=$(BUILD)/%.o)
# the tool (src/tool: run folders, sweeps, output staging, the row filters)
# and the command line (src/cli): linked into the poolreps executable alone.
# Besides the public headers they see the library's private ones
# (src/private/poolreps: CSV plumbing and what the command needs beyond the
# public API), which libpoolreps.so does not export and make install does
# not install; the command line sees the tool's headers (src/tool/poolreps).
TOOL_SRC := $(wildcard src/tool/*.c)
TOOL_OBJ := $(TOOL_SRC:src/%.c=$(BUILD)/%.o)
TOOL_LIB := $(BUILD)/libpoolreps_tool.a
CLI_SRC := $(wildcard src/cli/*.c)
CLI_OBJ := $(CLI_SRC:src/%.c=$(BUILD)/%.o)
CLI_CFLAGS = $(WARN) $(DEFS) -Iinclude -Isrc/private -Isrc/tool $(shell pkg-config --cflags $(PKGS) 2>/dev/null) $(CFLAGS) -MMD -MP
LIB     := $(BUILD)/libpoolreps.a
TEST_SRC := $(wildcard tests/test_*.c)
TEST_BIN := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)

.PHONY: all lib check check-c check-py bench reproduce reproduce-run deps install clean fuzz valgrind man power exp4-study study verdicts sensitivity quick-sums FORCE
.PHONY: shared install-lib examples python check-pybind bench-bin fuzz-bin venv baselines
.PHONY: coverage

all: poolreps

lib: $(LIB)

# flags live here: a changed Makefile rebuilds everything
$(LIB_OBJ) $(TOOL_OBJ) $(CLI_OBJ): Makefile

$(BUILD)/%.o: src/%.c | $(BUILD)
	$(CC) $(ALL_CFLAGS) -c $< -o $@

$(BUILD)/cli/%.o: src/cli/%.c | $(BUILD)/cli
	$(CC) $(CLI_CFLAGS) -c $< -o $@

$(BUILD)/tool/%.o: src/tool/%.c | $(BUILD)/tool
	$(CC) $(ALL_CFLAGS) -Isrc/tool -c $< -o $@

$(BUILD):
	mkdir -p $(BUILD)/tests

$(BUILD)/cli $(BUILD)/tool:
	mkdir -p $@

# the version string is compiled into common.o: rebuild it when git describe changes
$(BUILD)/version.stamp: FORCE | $(BUILD)
	@echo '$(VERSION)' | cmp -s - $@ || echo '$(VERSION)' > $@
$(BUILD)/common.o: $(BUILD)/version.stamp
FORCE:

$(LIB): $(LIB_OBJ)
	rm -f $@
	ar rcs $@ $^

$(TOOL_LIB): $(TOOL_OBJ)
	rm -f $@
	ar rcs $@ $^

$(BUILD)/poolreps: $(CLI_OBJ) $(TOOL_LIB) $(LIB)
	$(CC) $(LDFLAGS) $^ $(LIBS) -o $@

poolreps: $(BUILD)/poolreps
	cp $< $@

$(BUILD)/tests/%: tests/%.c $(LIB) | $(BUILD)
	$(CC) $(ALL_CFLAGS) $(LDFLAGS) $< $(LIB) $(LIBS) -lcmocka -o $@

# the command line's option tables and help: src/cli without its main
CLI_TABLES_OBJ := $(filter-out $(BUILD)/cli/main.o,$(CLI_OBJ))
$(BUILD)/tests/test_cli_opts: tests/test_cli_opts.c $(CLI_TABLES_OBJ) $(TOOL_LIB) $(LIB) | $(BUILD)
	$(CC) $(ALL_CFLAGS) -Isrc/tool $(LDFLAGS) $< $(CLI_TABLES_OBJ) $(TOOL_LIB) $(LIB) $(LIBS) -lcmocka -o $@

# the tool's own tests (tests/test_tool_*.c) link it too
$(BUILD)/tests/test_tool_%: tests/test_tool_%.c $(TOOL_LIB) $(LIB) | $(BUILD)
	$(CC) $(ALL_CFLAGS) -Isrc/tool $(LDFLAGS) $< $(TOOL_LIB) $(LIB) $(LIBS) -lcmocka -o $@

# the packages are probed when make starts (below); nothing is installed here.
# Everything is built first, so that the C tests and `make verdicts CHECK=1`
# run alongside pytest (JOBS workers, pytest-xdist) without two makes
# compiling the same objects; their output is held in build/ and printed
# after pytest's, which names the 10 slowest tests. The last line is the
# wall time of the whole check.
CHECK_LOG = $(BUILD)/check
check:
	@t0=$$(date +%s); st=0; \
	  $(MAKE) -j$(JOBS) $(TEST_BIN) $(BUILD)/poolreps $(BUILD)/tests/ref_driver $(SOLIB) || exit $$?; \
	  $(if $(filter 1,$(COV)),find $(BUILD) -name '*.gcda' -delete;) \
	  mkdir -p $(CHECK_LOG); \
	  { $(MAKE) --no-print-directory check-c > $(CHECK_LOG)/c.log 2>&1; echo $$? > $(CHECK_LOG)/c.rc; } & \
	  { $(MAKE) --no-print-directory verdicts CHECK=1 > $(CHECK_LOG)/verdicts.log 2>&1; \
	    echo $$? > $(CHECK_LOG)/verdicts.rc; } & \
	  $(MAKE) check-py || st=$$?; wait; \
	  for part in c verdicts; do echo "== make check: $$part (ran alongside pytest)"; \
	    cat $(CHECK_LOG)/$$part.log; [ "$$(cat $(CHECK_LOG)/$$part.rc)" = 0 ] || st=1; done; \
	  $(if $(filter 1,$(COV)),$(PYTHON) scripts/coverage.py $(BUILD) || st=1;) \
	  echo "make check: $$(( $$(date +%s) - t0 )) s wall"; exit $$st

# the coverage of what ran since the objects were built (after a partial run)
coverage:
	$(PYTHON) scripts/coverage.py build/cov

check-c: $(TEST_BIN)
	@fail=0; for t in $(TEST_BIN); do echo "== $$t"; $$t || fail=1; done; exit $$fail

# tests/ref_driver exposes library calls to the numpy reference tests
check-py: $(BUILD)/poolreps $(BUILD)/tests/ref_driver
	LC_ALL=C SAN=$(SAN) POOLREPS=$(abspath $(BUILD)/poolreps) PYTHON=$(PYTHON) $(PYTHON) -m pytest -q -n $(JOBS) --dist loadgroup --durations=10 tests

# the scripts build their binaries through the rules below (bench-bin, fuzz-bin)
bench: all
	@for b in scripts/bench_*.sh; do echo "== $$b"; MAKE="$(MAKE)" PYTHON="$(PYTHON)" sh $$b || exit 1; done

FUZZ_SECONDS ?= 20
fuzz:
	MAKE="$(MAKE)" FUZZ_CC="$(FUZZ_CC)" sh scripts/fuzz.sh $(FUZZ_SECONDS)

# the libFuzzer harnesses: `make FUZZ=1 fuzz-bin` (scripts/fuzz.sh does)
FUZZ_BIN := $(patsubst tests/fuzz/%.c,$(BUILD)/%,$(wildcard tests/fuzz/fuzz_*.c))
fuzz-bin: $(FUZZ_BIN)
$(FUZZ_BIN): $(BUILD)/fuzz_%: tests/fuzz/fuzz_%.c tests/fuzz/fuzz_common.h $(TOOL_LIB) $(LIB)
	$(CC) $(ALL_CFLAGS) -Isrc/tool $(LDFLAGS) -fsanitize=fuzzer $< $(filter %.o,$^) $(TOOL_LIB) $(LIB) $(LIBS) -o $@

valgrind: $(BUILD)/poolreps $(SOLIB)
	POOLREPS_LIB=$(abspath $(SOLIB)) sh scripts/valgrind.sh $(abspath $(BUILD)/poolreps) "$(PYTHON)"

# docs/poolreps.1 and docs/parameters.md from --help and --help-keys;
# tests/test_cli.py and tests/test_readme.py fail until this is rerun after a
# help change
man: $(BUILD)/poolreps
	sh scripts/gen-man.sh $(BUILD)/poolreps docs/poolreps.1
	sh scripts/gen-params.sh $(BUILD)/poolreps docs/parameters.md

# tests/data/quick_reproduce.sha256: the bytes of every CSV of the quick
# reproduction (tests/test_report.py compares); rerun only when results are
# meant to change
quick-sums: $(BUILD)/poolreps
	sh scripts/gen-quick-sums.sh $(abspath $(BUILD)/poolreps) "$(PYTHON)"

deps:
	sh scripts/install-deps.sh $(if $(EXTRAS),--extras)

# sub-makes, so that PYTHON and pkg-config are looked up after deps installed
# them; timed from before the build (scripts/reproduce-timed.sh)
reproduce: deps
	sh scripts/reproduce-timed.sh "$(MAKE)" "$(JOBS)" "$(OUT)"

reproduce-run:
	sh scripts/reproduce.sh "$(OUT)" "$(PYTHON)" "$(QUICK)"

# A standalone Experiment 3 power study (not part of reproduce): its report
# goes to OUT/power; docs/power.md describes the verdict study (make verdicts).
POWER_REPS ?= 50
POWER_ARGS ?=
POWER_DOCS ?= $(OUT)/power
power: all
	sh scripts/power.sh "$(OUT)/power" "$(POWER_REPS)" "$(POWER_DOCS)" "$(PYTHON)" $(POWER_ARGS)

# Experiment 4 controls study (docs/exp4.md, "Controls"; not part of
# reproduce): data/exp4_controls.ini in six arms, EXP4_STUDY_REPS paired
# repetitions. Only the default study writes docs/ and README.md.
EXP4_STUDY_REPS ?= 20
EXP4_STUDY_ARGS ?=
ifeq ($(EXP4_STUDY_REPS)$(EXP4_STUDY_ARGS),20)
  EXP4_STUDY_DOCS ?= docs
else
  EXP4_STUDY_DOCS ?= $(OUT)/exp4_study_docs
endif
exp4-study: all
	sh scripts/exp4_study.sh "$(OUT)/exp4_study" "$(EXP4_STUDY_REPS)" "$(EXP4_STUDY_DOCS)" "$(PYTHON)" $(EXP4_STUDY_ARGS)

# The study behind every verdict (docs/verdicts.md; not part of reproduce):
# Experiment 3 as `make power`, Experiments 1 and 2 at STUDY_SEEDS seeds; its
# compact results go to data/study/ (committed), then `make verdicts`.
STUDY_SEEDS ?= 20
study: all
	sh scripts/study.sh "$(OUT)/study" "$(POWER_REPS)" "$(STUDY_SEEDS)" data/study "$(PYTHON)"
	$(MAKE) verdicts

# docs/verdicts.md, docs/verdicts_report.html and the README's verdict table
# from data/study/, and Experiment 4's answer (docs/exp4.md, README.md) from
# docs/exp4_study/; CHECK=1 writes nothing and fails on a difference
verdicts:
	$(PYTHON) scripts/verdicts.py data/study $(if $(CHECK),--check)
	$(PYTHON) scripts/exp4_study.py docs docs/exp4_study --doc docs/exp4.md --readme README.md $(if $(CHECK),--check)
	$(MAKE) --no-print-directory baselines-report

# Sensitivity study (docs/sensitivity.md): Experiment 3's verdicts with one
# open choice changed at a time. The default size writes docs/ and the README
# sentence; QUICK=1 (tiny runs, 3 repetitions; tests/test_sensitivity.py) and
# other sizes write OUT/sensitivity/docs.
SENSITIVITY_REPS ?= 20
SENSITIVITY_QUICK_ARGS := --set exp3.iterations=3 --set exp3.init_samples=60 --set exp3.window=60 \
  --set exp3.samples=20 --set exp3.final_episodes=30 --set policy.n_min=20 --set exp3.baseline_n_min=100 \
  --set value.n_min=15 --set value.trees=3 --set policy.trees=3
ifeq ($(QUICK),1)
  SENSITIVITY_RUN = 3 "$(OUT)/sensitivity/docs" "$(PYTHON)" $(SENSITIVITY_QUICK_ARGS)
else ifeq ($(SENSITIVITY_REPS),20)
  SENSITIVITY_RUN = 20 docs "$(PYTHON)"
else
  SENSITIVITY_RUN = $(SENSITIVITY_REPS) "$(OUT)/sensitivity/docs" "$(PYTHON)"
endif
sensitivity: all
	mkdir -p "$(OUT)/sensitivity/docs"
	sh scripts/sensitivity.sh "$(OUT)/sensitivity" $(SENSITIVITY_RUN)

install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/poolreps/data/quick \
	  $(DESTDIR)$(PREFIX)/share/poolreps/scripts $(DESTDIR)$(PREFIX)/share/man/man1
	install -m 755 poolreps $(DESTDIR)$(PREFIX)/bin/poolreps
	install -m 644 data/*.ini $(DESTDIR)$(PREFIX)/share/poolreps/data
	install -m 644 data/quick/*.ini $(DESTDIR)$(PREFIX)/share/poolreps/data/quick
	install -m 755 scripts/*.py scripts/*.sh scripts/plot $(DESTDIR)$(PREFIX)/share/poolreps/scripts
	install -m 644 scripts/power_template.md $(DESTDIR)$(PREFIX)/share/poolreps/scripts
	install -d $(DESTDIR)$(PREFIX)/share/poolreps/docs
	install -m 644 docs/verdicts_report.html $(DESTDIR)$(PREFIX)/share/poolreps/docs
	install -m 644 docs/poolreps.1 $(DESTDIR)$(PREFIX)/share/man/man1

clean:
	rm -rf build poolreps python/poolreps/libpoolreps.so.*

# ---- the library for other programs: shared object, install, examples ----
# Every library object is compiled once, position-independent, and goes into
# both libpoolreps.a and libpoolreps.so: Debian's gcc builds PIE executables,
# so the CLI's objects were position-independent already, and
# -fno-semantic-interposition keeps calls inside the library direct.
LIB_VERSION := 0.1.0
SO_MAJOR := 0
SONAME   := libpoolreps.so.$(SO_MAJOR)
SOLIB    := $(BUILD)/libpoolreps.so.$(LIB_VERSION)
LIBDIR   ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
STAGE    := $(abspath $(BUILD)/stage)

$(LIB_OBJ): CFLAGS += -fPIC -fno-semantic-interposition

all: $(SOLIB)
shared: $(SOLIB)

# src/libpoolreps.map: the exports, exactly what include/poolreps/*.h declare
# (scripts/exports.py writes it; tests/test_exports.py checks it against nm -D)
$(SOLIB): $(LIB_OBJ) src/libpoolreps.map
	$(CC) -shared -Wl,-soname,$(SONAME) -Wl,-z,defs -Wl,--version-script=src/libpoolreps.map $(LDFLAGS) $(LIB_OBJ) $(LIBS) -o $@
	ln -sf libpoolreps.so.$(LIB_VERSION) $(BUILD)/$(SONAME)
	ln -sf $(SONAME) $(BUILD)/libpoolreps.so

install: install-lib

install-lib: $(LIB) $(SOLIB)
	install -d $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR)/poolreps
	install -m 644 $(LIB) $(DESTDIR)$(LIBDIR)/libpoolreps.a
	install -m 755 $(SOLIB) $(DESTDIR)$(LIBDIR)/libpoolreps.so.$(LIB_VERSION)
	ln -sf libpoolreps.so.$(LIB_VERSION) $(DESTDIR)$(LIBDIR)/$(SONAME)
	ln -sf $(SONAME) $(DESTDIR)$(LIBDIR)/libpoolreps.so
	install -m 644 include/poolreps/*.h $(DESTDIR)$(INCLUDEDIR)/poolreps
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@LIBDIR@|$(LIBDIR)|' -e 's|@INCLUDEDIR@|$(INCLUDEDIR)|' \
	  -e 's|@VERSION@|$(LIB_VERSION)|' poolreps.pc.in > $(DESTDIR)$(LIBDIR)/pkgconfig/poolreps.pc

# examples/*.c built the way a user builds them: against an installed tree
# (staged under $(STAGE)) through pkg-config; tests/test_examples.py runs them
examples: $(LIB) $(SOLIB)
	rm -rf $(STAGE)
	$(MAKE) --no-print-directory install-lib DESTDIR=$(STAGE) PREFIX=/usr/local LIBDIR=/usr/local/lib
	sh scripts/build-examples.sh "$(STAGE)" /usr/local/lib $(BUILD)/examples "$(CC)" "$(CFLAGS) $(LDFLAGS)"

check-py: examples $(SOLIB)
check-py: export POOLREPS_LIB := $(abspath $(SOLIB))
check-py: export POOLREPS_EXAMPLES := $(abspath $(BUILD)/examples)
check-py: export POOLREPS_STAGE := $(STAGE)

# Under SAN=1 Python loads the sanitized library only with the sanitizer
# runtimes preloaded: the binding's tests run apart, with them and with the
# interpreter's own leaks suppressed (the pip test needs no second run)
ifeq ($(SAN),1)
# the test files that import the package when pytest collects them
# (test_runtime_libs reads the library's NEEDED list, which the sanitizers
# change: it runs in the plain build only)
PYBIND_TESTS := tests/test_python.py tests/test_gym.py tests/test_api_strict.py \
  tests/test_learner_python.py tests/test_shot_params.py tests/test_learner_bench.py
check-py: export PYTEST_ADDOPTS := $(patsubst %,--ignore=%,$(PYBIND_TESTS)) \
  --ignore=tests/test_python_install.py --ignore=tests/test_runtime_libs.py
check-py: check-pybind
check-pybind: $(SOLIB) $(BUILD)/poolreps
	PYTEST_ADDOPTS= LC_ALL=C POOLREPS=$(abspath $(BUILD)/poolreps) POOLREPS_LIB=$(abspath $(SOLIB)) \
	  LD_PRELOAD="$(shell $(CC) -print-file-name=libasan.so) $(shell $(CC) -print-file-name=libubsan.so)" \
	  LSAN_OPTIONS=suppressions=$(abspath tests/lsan-python.supp):print_suppressions=0 \
	  $(PYTHON) -m pytest -q -p no:cacheprovider -m "not native" \
	  -k "not fast_enough" $(PYBIND_TESTS)
endif

# Experiment 5 (docs/baselines.md): SB3 (CPU torch) and pycma from PyPI in
# build/baselines/venv, every run into OUT/baselines, data/baselines/*.csv,
# docs/baselines.md and docs/figures/baselines.png. Not part of reproduce.
BASELINES_SEEDS ?= 10
baselines: all
	POOLREPS=$(abspath $(BUILD)/poolreps) PYTHON=$(PYTHON) BASELINES_DATA=data/baselines \
	  BASELINES_DOCS=docs BASELINES_README=README.md sh scripts/baselines.sh run "$(OUT)/baselines" $(BASELINES_SEEDS)

# docs/baselines.md, its figures and the README's Experiment 5 paragraph
# from data/baselines (no runs); CHECK=1 writes nothing and fails on a difference
.PHONY: baselines-report
baselines-report:
	$(PYTHON) scripts/baselines_report.py report data/baselines docs README.md $(if $(CHECK),--check)

# build/venv: the system's Python packages plus Gymnasium from PyPI (not a
# Debian package), for tests/test_gym.py (which skips without it), mypy
# for its typing test, and pycma (the baselines' pinned version) for
# scripts/bench_learner.sh's ask/tell peer
venv: build/venv/.done
build/venv/.done:
	/usr/bin/python3 -m venv --system-site-packages build/venv
	build/venv/bin/pip install -q gymnasium
	build/venv/bin/pip install -q mypy
	build/venv/bin/pip install -q cma==4.5.0
	touch $@

# the Python package: the library next to it, so that `pip install ./python`
# carries it (the package also finds build/rel or an installed copy)
python: $(SOLIB)
	cp $(SOLIB) python/poolreps/$(SONAME)
	cd python && PYTHONPATH=. $(PYTHON) -c 'import poolreps; print("poolreps", poolreps.__version__, "from", poolreps.library_path())'

# the C benches of tests/bench (scripts/bench_*.sh build them through here)
BENCH_BIN := $(patsubst tests/bench/%.c,$(BUILD)/%,$(wildcard tests/bench/*.c))
bench-bin: $(BENCH_BIN)
$(BENCH_BIN): $(BUILD)/bench_%: tests/bench/bench_%.c $(LIB)
	$(CC) $(ALL_CFLAGS) $(LDFLAGS) $< $(LIB) $(LIBS) -o $@

# Before compiling anything, one line naming the missing Debian packages
# rather than a wall of compiler errors (probed once per build folder; the
# test packages each time a check target runs). `reproduce` and `deps` install
# the packages as root, so they are not probed here; without root they stop at
# once with the one line of scripts/install-deps.sh and exit 2.
INSTALL_GOALS := deps reproduce
ifneq ($(filter $(INSTALL_GOALS),$(MAKECMDGOALS)),)
  ifneq ($(shell id -u),0)
    DEPS_MISSING := $(shell sh scripts/install-deps.sh --probe $(if $(EXTRAS),--extras) 2>&1)
    ifneq ($(DEPS_MISSING),)
      $(error $(DEPS_MISSING))
    endif
  endif
else ifeq ($(filter clean,$(MAKECMDGOALS)),)
  ifeq ($(wildcard $(BUILD)/deps.ok),)
    DEPS_MISSING := $(shell CC='$(CC)' sh scripts/check-deps.sh build)
    ifneq ($(DEPS_MISSING),)
      # dpkg's list names every missing package at once (without a compiler
      # the header probes cannot tell); the probe's own line where dpkg
      # knows of nothing missing (another compiler, a non-Debian system)
      $(error $(or $(shell sh scripts/install-deps.sh --probe 2>&1),$(DEPS_MISSING)))
    endif
    $(shell mkdir -p $(BUILD)/tests && touch $(BUILD)/deps.ok)
  endif
  ifneq ($(filter check check-c check-py,$(MAKECMDGOALS)),)
    DEPS_MISSING := $(shell CC='$(CC)' sh scripts/check-deps.sh check "$(PYTHON)")
    ifneq ($(DEPS_MISSING),)
      $(error $(or $(shell sh scripts/install-deps.sh --probe 2>&1),$(DEPS_MISSING)))
    endif
  endif
endif

-include $(LIB_OBJ:.o=.d) $(TOOL_OBJ:.o=.d) $(CLI_OBJ:.o=.d)

# The holdout of the verdicts (docs/verdicts.md): Experiment 3 with a seed no
# study used, into data/study/holdout/ (committed), then `make verdicts`.
HOLDOUT_REPS ?= 100
HOLDOUT_SEED ?= 37037
.PHONY: holdout
holdout: all
	sh scripts/holdout.sh "$(OUT)/holdout" "$(HOLDOUT_REPS)" "$(HOLDOUT_SEED)" data/study/holdout "$(PYTHON)"
	$(MAKE) verdicts
