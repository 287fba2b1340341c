# poolreps — see README.md. `make reproduce` and `make check` are the two entry points.
CC      ?= cc
CFLAGS  ?= -O2 -g
PREFIX  ?= /usr/local
PYTHON  ?= $(shell for p in /usr/bin/python3 python3; do $$p -c 'import matplotlib' 2>/dev/null && { command -v $$p; break; }; done)
OUT     ?= results

VERSION := $(shell git describe --always --dirty --tags 2>/dev/null || cat VERSION 2>/dev/null || echo 0.1.0)
WARN    := -std=c11 -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes
DEFS    := -D_POSIX_C_SOURCE=200809L -DHAVE_INLINE -DPR_VERSION_STR='"$(VERSION)"'
PKGS    := gsl nlopt
ifeq ($(SAN),1)
  CFLAGS += -O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
  LDFLAGS += -fsanitize=address,undefined
  BUILD := build/san
else
  BUILD := build/rel
endif
ALL_CFLAGS = $(WARN) $(DEFS) -Iinclude -Isrc $(shell pkg-config --cflags $(PKGS)) $(CFLAGS) -MMD -MP
LIBS    := $(shell pkg-config --libs $(PKGS)) -lcsv -linih -lpthread -lm

LIB_SRC := $(filter-out src/main.c,$(wildcard src/*.c))
LIB_OBJ := $(LIB_SRC:src/%.c=$(BUILD)/%.o)
LIB     := $(BUILD)/libpoolreps.a
TEST_SRC := $(wildcard tests/test_*.c)
TEST_BIN := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)

.PHONY: all lib check check-c check-py bench reproduce reproduce-run deps install clean fuzz valgrind man power FORCE

all: poolreps

lib: $(LIB)

# flags live here: a changed Makefile rebuilds everything
$(LIB_OBJ) $(BUILD)/main.o: Makefile

$(BUILD)/%.o: src/%.c | $(BUILD)
	$(CC) $(ALL_CFLAGS) -c $< -o $@

$(BUILD):
	mkdir -p $(BUILD)/tests

# the version string is compiled into common.o: rebuild it when git describe changes
$(BUILD)/version.stamp: FORCE | $(BUILD)
	@echo '$(VERSION)' | cmp -s - $@ || echo '$(VERSION)' > $@
$(BUILD)/common.o: $(BUILD)/version.stamp
FORCE:

$(LIB): $(LIB_OBJ)
	rm -f $@
	ar rcs $@ $^

$(BUILD)/poolreps: $(BUILD)/main.o $(LIB)
	$(CC) $(LDFLAGS) $^ $(LIBS) -o $@

poolreps: $(BUILD)/poolreps
	cp $< $@

$(BUILD)/tests/%: tests/%.c $(LIB) | $(BUILD)
	$(CC) $(ALL_CFLAGS) $(LDFLAGS) $< $(LIB) $(LIBS) -lcmocka -o $@

# deps first (a no-op when everything is installed), then a sub-make that
# looks up PYTHON and pkg-config flags with the packages in place
check: deps
	$(MAKE) check-c check-py

check-c: $(TEST_BIN)
	@fail=0; for t in $(TEST_BIN); do echo "== $$t"; $$t || fail=1; done; exit $$fail

# tests/ref_driver exposes library calls to the numpy reference tests
check-py: $(BUILD)/poolreps $(BUILD)/tests/ref_driver
	LC_ALL=C SAN=$(SAN) POOLREPS=$(abspath $(BUILD)/poolreps) PYTHON=$(PYTHON) $(PYTHON) -m pytest -q tests

bench: all
	@for b in scripts/bench_*.sh; do echo "== $$b"; CC="$(CC)" PYTHON="$(PYTHON)" sh $$b || exit 1; done

FUZZ_SECONDS ?= 20
fuzz:
	sh scripts/fuzz.sh $(FUZZ_SECONDS)

valgrind: $(BUILD)/poolreps
	sh scripts/valgrind.sh $(abspath $(BUILD)/poolreps) "$(PYTHON)"

# docs/poolreps.1 and the README's key list from --help; tests/test_cli.py and
# tests/test_readme.py fail until this is rerun after a help change
man: $(BUILD)/poolreps
	sh scripts/gen-man.sh $(BUILD)/poolreps docs/poolreps.1
	sh scripts/gen-readme-keys.sh $(BUILD)/poolreps README.md

deps:
	sh scripts/install-deps.sh

# a sub-make, so that PYTHON and pkg-config are looked up after deps installed them
reproduce: deps
	$(MAKE) all
	$(MAKE) reproduce-run

reproduce-run:
	sh scripts/reproduce.sh "$(OUT)" "$(PYTHON)" "$(QUICK)"

# Experiment 3 power study (docs/power.md; not part of reproduce). Only the
# default study writes docs/ and the README column; others write OUT/power.
POWER_REPS ?= 50
POWER_ARGS ?=
ifeq ($(POWER_REPS)$(POWER_ARGS),50)
  POWER_DOCS ?= docs
else
  POWER_DOCS ?= $(OUT)/power
endif
power: all
	sh scripts/power.sh "$(OUT)/power" "$(POWER_REPS)" "$(POWER_DOCS)" "$(PYTHON)" $(POWER_ARGS)

install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/poolreps/data \
	  $(DESTDIR)$(PREFIX)/share/poolreps/scripts $(DESTDIR)$(PREFIX)/share/man/man1
	install -m 755 poolreps $(DESTDIR)$(PREFIX)/bin/poolreps
	install -m 644 data/*.ini $(DESTDIR)$(PREFIX)/share/poolreps/data
	install -m 755 scripts/*.py scripts/*.sh scripts/plot $(DESTDIR)$(PREFIX)/share/poolreps/scripts
	install -m 644 scripts/power_template.md $(DESTDIR)$(PREFIX)/share/poolreps/scripts
	install -m 644 docs/poolreps.1 $(DESTDIR)$(PREFIX)/share/man/man1

clean:
	rm -rf build poolreps

-include $(LIB_OBJ:.o=.d) $(BUILD)/main.d
