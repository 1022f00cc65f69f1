# qmcd build.  One static library per layer, linked by the CLI, the daemon
# and the tests.  Sources are picked up by wildcard so adding a module means
# adding a file, not editing this one.
#
#   make            libraries and the qmc CLI
#   make check      installs test packages, runs all tests plain and under
#                   ASan+UBSan, fuzzes briefly, and fails on any SILENT cell
#                   of qmc stability --quick
#   make sanitize   the sanitized build and its tests only
#   make demo       installs packages, builds, shows the sampling core
#   make bench      installs peers (GSL, cubature), runs benchmarks
#   make install    PREFIX=/usr/local DESTDIR= (make uninstall reverses it)

CC       ?= cc
BUILD    ?= build
PREFIX   ?= /usr/local
OPT      ?= -O2 -g
WARN     := -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes \
            -Wmissing-prototypes -Wpointer-arith -Wformat=2
# -ffp-contract=off: no fused multiply-adds, so results are bit-identical
# whichever compiler or flags build them.
CFLAGS   := -std=c11 $(WARN) -ffp-contract=off -fPIC $(OPT) \
            -D_POSIX_C_SOURCE=200809L -Iinclude $(EXTRA_CFLAGS)
# libsodium: HMAC-SHA256 and constant-time compares for the handshake
# (protocol/auth.c), in every program that links the protocol library.
SODIUM_LIBS := $(shell pkg-config --libs libsodium 2>/dev/null || echo -lsodium)
LDLIBS   := -lm $(SODIUM_LIBS)
DAEMON_LIBS := $(shell pkg-config --libs libsystemd 2>/dev/null)
# libmodbus: the daemon's RTU line only (daemon/modbus_rtu.c); the Modbus
# tests' C client and the benchmark's peer server link it too.
MODBUS_CFLAGS := $(shell pkg-config --cflags libmodbus 2>/dev/null)
MODBUS_LIBS   := $(shell pkg-config --libs libmodbus 2>/dev/null)
DEPFLAGS  = -MMD -MP

CORE_SRC    := $(wildcard core/*.c)
CORE_OBJ    := $(CORE_SRC:%.c=$(BUILD)/%.o) $(BUILD)/gen/sobol_table.o
PROTO_SRC   := $(wildcard protocol/*.c)
PROTO_OBJ   := $(PROTO_SRC:%.c=$(BUILD)/%.o)
CLIENT_SRC  := $(wildcard client/lib/*.c)
CLIENT_OBJ  := $(CLIENT_SRC:%.c=$(BUILD)/%.o)
DAEMON_SRC  := $(wildcard daemon/*.c)
DAEMON_OBJ  := $(DAEMON_SRC:%.c=$(BUILD)/%.o)
CLI_SRC     := $(wildcard client/cli/*.c)
CLI_OBJ     := $(CLI_SRC:%.c=$(BUILD)/%.o)
UNIT_SRC    := $(wildcard tests/unit/test_*.c)
UNIT_BIN    := $(UNIT_SRC:tests/unit/%.c=$(BUILD)/tests/%)
UNIT_HELPER := $(filter-out $(UNIT_SRC),$(wildcard tests/unit/*.c))
BENCH_SRC   := $(wildcard bench/bench_*.c)
BENCH_BIN   := $(BENCH_SRC:bench/%.c=$(BUILD)/bench/%)

LIBQMC    := $(BUILD)/libqmc.a
LIBPROTO  := $(BUILD)/libqmcproto.a
LIBCLIENT := $(BUILD)/libqmcclient.a
SOCLIENT  := $(BUILD)/libqmcclient.so
QMC       := $(BUILD)/qmc
QMCD      := $(BUILD)/qmcd
# Every layer's libraries, outermost first, for programs that use them all.
ALL_LIBS  := $(LIBCLIENT) $(LIBPROTO) $(LIBQMC)

.PHONY: all check test sanitize demo bench install uninstall clean deps-build deps-test \
        deps-bench lint-seams lint-symbols fuzz
.DELETE_ON_ERROR:

all: $(ALL_LIBS) $(SOCLIENT) $(BUILD)/qmcclient.pc $(QMC) $(if $(DAEMON_SRC),$(QMCD))

# ---- generated data -------------------------------------------------------
JOE_KUO        := data/new-joe-kuo-6.21201
JOE_KUO_SHA256 := 68eedd2a4e3b659b9695e7aff0f8ac68718bcf620730fc3d3a8c65df2a067441

$(BUILD)/gen/sobol_table.c: $(JOE_KUO) build-aux/gen-sobol-table.awk
	@mkdir -p $(@D)
	@echo "$(JOE_KUO_SHA256)  $(JOE_KUO)" | sha256sum -c --quiet - || \
	  { echo "make: $(JOE_KUO) does not match its recorded sha256" >&2; exit 1; }
	awk -f build-aux/gen-sobol-table.awk $(JOE_KUO) > $@

# ---- objects and libraries --------------------------------------------------
# Only core/ sees core's private headers; every other layer goes through
# include/qmc/ like any outside user.
$(BUILD)/core/%.o: PRIVATE_INC := -Icore
# The AVX2 and AVX-512 builds of the Sobol kernels; called only on CPUs
# that have them (see core/seq_sobol.c).
ifeq ($(shell uname -m),x86_64)
$(BUILD)/core/seq_sobol_avx2.o: PRIVATE_INC := -Icore -mavx2
$(BUILD)/core/seq_sobol_avx512.o: PRIVATE_INC := -Icore -mavx512f -mavx512vl \
                                                -mavx512bw -mavx512dq -mavx512vbmi -mgfni
$(BUILD)/core/pixel_kernel_avx2.o: PRIVATE_INC := -Icore -mavx2
$(BUILD)/core/pixel_kernel_avx512.o: PRIVATE_INC := -Icore -mavx512f -mavx512vl -mavx512bw -mavx512dq
endif
$(BUILD)/daemon/modbus_rtu.o: PRIVATE_INC := $(MODBUS_CFLAGS)
$(BUILD)/%.o: %.c
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(PRIVATE_INC) $(DEPFLAGS) -c $< -o $@

$(BUILD)/gen/sobol_table.o: $(BUILD)/gen/sobol_table.c
	$(CC) $(CFLAGS) -Icore -c $< -o $@

$(LIBQMC): $(CORE_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(LIBPROTO): $(PROTO_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(LIBCLIENT): $(CLIENT_OBJ)
	@rm -f $@
	ar rcs $@ $^

# The shared client library carries the codec and the core it needs, so a
# user links -lqmcclient alone (pkg-config qmcclient).
$(SOCLIENT): $(CLIENT_OBJ) $(PROTO_OBJ) $(CORE_OBJ)
	$(CC) -shared -Wl,-soname,libqmcclient.so.0 -o $@ $^ -lm $(SODIUM_LIBS) -pthread $(LDFLAGS)

# (install writes its own copy for its PREFIX)
$(BUILD)/qmcclient.pc: client/qmcclient.pc.in
	sed -e 's|@PREFIX@|$(PREFIX)|g' $< > $@

# The CLI links the client library exactly as any other user would
# (LDLIBS' libsodium also gives it the SHA-256 of --part files).
$(QMC): $(CLI_OBJ) $(ALL_LIBS)
	$(CC) $(CFLAGS) -pthread -o $@ $(CLI_OBJ) $(ALL_LIBS) $(LDLIBS) $(LDFLAGS)

$(QMCD): $(DAEMON_OBJ) $(LIBPROTO) $(LIBQMC)
	$(CC) $(CFLAGS) -pthread -o $@ $(DAEMON_OBJ) $(LIBPROTO) $(LIBQMC) $(LDLIBS) \
	  $(DAEMON_LIBS) $(MODBUS_LIBS) $(LDFLAGS)

# ---- tests --------------------------------------------------------------------
$(BUILD)/tests/test_%: tests/unit/test_%.c $(UNIT_HELPER) $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -Icore -Iprotocol -Itests/unit $(UNIT_DAEMON_INC) $(DEPFLAGS) -o $@ $< \
	  $(UNIT_HELPER) $(UNIT_DAEMON_OBJ) $(ALL_LIBS) -lcmocka -pthread $(LDLIBS) $(LDFLAGS)

# Unit tests of daemon modules link just the daemon objects they test (the
# daemon is a program, not a library): one line per test.
$(BUILD)/tests/test_peers: UNIT_DAEMON_OBJ := $(BUILD)/daemon/peers.o
$(BUILD)/tests/test_peers: UNIT_DAEMON_INC := -Idaemon
$(BUILD)/tests/test_peers: $(BUILD)/daemon/peers.o
$(BUILD)/tests/test_pool: UNIT_DAEMON_OBJ := $(BUILD)/daemon/pool.o $(BUILD)/daemon/log.o
$(BUILD)/tests/test_pool: UNIT_DAEMON_INC := -Idaemon
$(BUILD)/tests/test_pool: $(BUILD)/daemon/pool.o $(BUILD)/daemon/log.o
# test_integrate_memory counts libqmc's allocations through wrappers.
$(BUILD)/tests/test_integrate_memory: UNIT_DAEMON_OBJ := \
  -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=aligned_alloc,--wrap=free

# The CLI's file pieces (pure readers, outfile.c, pathwalk.c) have a unit
# test that links them beside the libraries.
CLI_UNIT_SRC := client/cli/linebuf.c client/cli/csv_read.c client/cli/part_read.c \
                client/cli/outfile.c client/cli/pathwalk.c client/cli/cli_common.c
$(BUILD)/tests/test_cli_files: tests/unit/test_cli_files.c $(CLI_UNIT_SRC) $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -Iclient/cli $(DEPFLAGS) -o $@ $< $(CLI_UNIT_SRC) $(ALL_LIBS) \
	  -lcmocka $(LDLIBS) $(LDFLAGS)

# The --command codec (pure, like the readers above).
CMD_UNIT_SRC := client/cli/command_codec.c client/cli/linebuf.c
$(BUILD)/tests/test_command_codec: tests/unit/test_command_codec.c $(CMD_UNIT_SRC) $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -Iclient/cli $(DEPFLAGS) -o $@ $< $(CMD_UNIT_SRC) -lcmocka -lm $(LDFLAGS)

# The Modbus e2e test's libmodbus master (tests/e2e/test_modbus.sh).
MODBUS_CLIENT := $(BUILD)/tests/modbus-client
$(MODBUS_CLIENT): tests/e2e/modbus_client.c
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(MODBUS_CFLAGS) -o $@ $< $(MODBUS_LIBS) $(LDFLAGS)

# The sessions e2e test's C peer (tests/e2e/test_sessions.sh): built-in
# integrands evaluated by a client of libqmcclient.
SESSION_PEER := $(BUILD)/tests/session-peer
$(SESSION_PEER): tests/e2e/session_peer.c $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -o $@ $< $(ALL_LIBS) -pthread $(LDLIBS) $(LDFLAGS)

# The plain suite: unit tests, end-to-end CLI tests, and the layering checks.
test: all $(UNIT_BIN) $(MODBUS_CLIENT) $(SESSION_PEER) lint-seams lint-symbols
	@set -e; for t in $(UNIT_BIN); do echo "== $$t"; $$t; done
	@set -e; for t in tests/e2e/test_*.sh; do echo "== $$t"; \
	  QMC=$(abspath $(QMC)) QMCD=$(abspath $(QMCD)) BUILD=$(abspath $(BUILD)) sh $$t; done

check: deps-test
	$(MAKE) test
	$(MAKE) sanitize
	$(MAKE) fuzz FUZZ_SECONDS=10
	$(MAKE) stability-gate

# Issue 13's gate: every method on every known failure case (qmc stability
# --quick, about a minute on 2 cores); any SILENT cell - a wrong answer with
# no flag - fails the build.  The report stays in $(BUILD)/stability.
.PHONY: stability-gate
stability-gate: all
	@if ! $(QMC) stability --quick --fail-on-silent --out $(BUILD)/stability; then \
	  echo "stability-gate: SILENT cells above (details: $(BUILD)/stability/REPORT.md)"; \
	  exit 1; fi

SAN_FLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined \
             -fno-sanitize-recover=all
sanitize: deps-test
	$(MAKE) BUILD=build/san CC=clang OPT="$(SAN_FLAGS)" \
	  LDFLAGS="-fsanitize=address,undefined" test

# core/ and protocol/ are pure computation: no I/O headers, no clock, no
# printing; and core/ knows nothing of the layers above it.  The daemon's
# largest ring of files that call each other may shrink, never grow.
lint-seams: $(DAEMON_OBJ)
	@bad=$$(grep -nE '#include <(stdio|unistd|sys/socket|netinet/[a-z]+|time|pthread)\.h>|\b(printf|fprintf|puts|abort|exit|getenv|clock_gettime|malloc_stats)\(' core/*.c core/*.h protocol/*.c protocol/*.h include/qmc/*.h 2>/dev/null || true); \
	  up=$$(grep -nE '#include "(qmc/proto|qmc/client)\.h"' core/*.c core/*.h 2>/dev/null || true); \
	  if [ -n "$$bad$$up" ]; then echo "lint-seams: I/O or an upward dependency:"; echo "$$bad$$up"; exit 1; fi; \
	  echo "lint-seams: core/ and protocol/ are pure; core/ depends on nothing above it"
	@/usr/bin/python3 tests/lint/daemon_ring.py --max 3 $(DAEMON_OBJ)

# Every exported symbol carries the qmc_ prefix.
lint-symbols: $(ALL_LIBS)
	@bad=$$(nm -g --defined-only $(ALL_LIBS) | awk 'NF==3 && $$3 !~ /^qmc_/ {print $$3}'); \
	  if [ -n "$$bad" ]; then echo "lint-symbols: unprefixed exports:"; echo "$$bad"; exit 1; fi; \
	  echo "lint-symbols: all exports carry qmc_"

# ---- fuzzing (clang libFuzzer, with ASan+UBSan) ------------------------------
# `make fuzz` runs every target for FUZZ_SECONDS each from its seed corpus;
# `make check` runs each briefly so a crash on the seeds fails the suite.
FUZZ_SRC     := $(wildcard tests/fuzz/fuzz_*.c)
FUZZ_BIN     := $(FUZZ_SRC:tests/fuzz/%.c=build/fuzz/%)
FUZZ_SECONDS ?= 60
FUZZ_FLAGS   := -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all

ifneq ($(BUILD),build/fuzz)
.PHONY: fuzz-lib
fuzz-lib:
	@$(MAKE) --no-print-directory BUILD=build/fuzz CC=clang \
	  OPT="-O1 -g -fsanitize=fuzzer-no-link,address,undefined" build/fuzz/libqmc.a \
	  build/fuzz/libqmcproto.a

# Targets take what they need from the protocol library (fuzz_auth) and
# the core; a target that drives code outside them lists those sources as
# FUZZ_SRCS_<name>, compiled into it with its flags.  A target that
# compiles sources in itself pulls nothing twice.
FUZZ_SRCS_config := daemon/config.c daemon/log.c daemon/modbus_spec.c daemon/regular_file.c
FUZZ_SRCS_csv    := client/cli/csv_read.c client/cli/linebuf.c
FUZZ_SRCS_part   := client/cli/part_read.c client/cli/linebuf.c
FUZZ_SRCS_command := client/cli/command_codec.c client/cli/linebuf.c
build/fuzz/fuzz_csv: $(FUZZ_SRCS_csv)
build/fuzz/fuzz_part: $(FUZZ_SRCS_part)
build/fuzz/fuzz_command: $(FUZZ_SRCS_command)
build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c fuzz-lib
	clang -std=c11 $(WARN) -ffp-contract=off $(FUZZ_FLAGS) -Iinclude -Idaemon -Iclient/cli -o $@ $< \
	  $(FUZZ_SRCS_$*) build/fuzz/libqmcproto.a build/fuzz/libqmc.a -lm $(SODIUM_LIBS)
endif

fuzz: deps-test $(FUZZ_BIN)
	@set -e; for f in $(FUZZ_BIN); do n=$$(basename $$f); mkdir -p build/fuzz/corpus-$$n; \
	  echo "== $$n ($(FUZZ_SECONDS) s)"; \
	  if ! $$f -max_total_time=$(FUZZ_SECONDS) -max_len=4096 \
	      -artifact_prefix=build/fuzz/ build/fuzz/corpus-$$n \
	      tests/fuzz/corpus/$${n#fuzz_} > build/fuzz/$$n.log 2>&1; then \
	    tail -n 30 build/fuzz/$$n.log; echo "fuzz: $$n failed (build/fuzz/$$n.log)"; exit 1; fi; \
	  tail -n 1 build/fuzz/$$n.log; done

# ---- benchmarks (peers live here only; GSL is GPL and never in the product) --
# bench_integrate's helpers (child runner, peers, convergence, report).
BENCH_INT_SRC := $(wildcard bench/integrate_*.c)
$(BUILD)/bench/bench_%: bench/bench_%.c $(LIBQMC)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -O3 -o $@ $< $(LIBQMC) -lgsl -lgslcblas -lcubature $(LDLIBS)

$(BUILD)/bench/bench_integrate: bench/bench_integrate.c $(BENCH_INT_SRC) \
                                $(wildcard bench/integrate_*.h) $(LIBQMC)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -O3 -Ibench -o $@ $< $(BENCH_INT_SRC) $(LIBQMC) -lgsl -lgslcblas \
	  -lcubature $(LDLIBS)

# The session benchmarks share their integrand and clock (session_common.c);
# the one through the daemon is a client of every layer.
BENCH_SESS := bench/session_common.c bench/session_common.h
$(BUILD)/bench/bench_session: bench/bench_session.c $(BENCH_SESS) $(LIBQMC)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -O3 -Ibench -o $@ $< bench/session_common.c $(LIBQMC) $(LDLIBS)

$(BUILD)/bench/bench_session_wire: bench/bench_session_wire.c $(BENCH_SESS) $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -O3 -Ibench -o $@ $< bench/session_common.c $(ALL_LIBS) -pthread $(LDLIBS) \
	  $(LDFLAGS)

# qmc-load, the daemon's load generator, speaks the protocol: every layer.
QMC_LOAD := $(BUILD)/bench/qmc-load
$(QMC_LOAD): bench/qmc_load.c $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) -o $@ $< $(ALL_LIBS) -pthread $(LDLIBS) $(LDFLAGS)

# pixels-load fetches pixel tiles from the daemon: every layer.
PIXELS_LOAD := $(BUILD)/bench/pixels-load
$(PIXELS_LOAD): bench/pixels_load.c $(ALL_LIBS)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) -o $@ $< $(ALL_LIBS) -pthread $(LDLIBS) $(LDFLAGS)

# The Modbus benchmark: a load generator (raw sockets, so a dribble is one
# byte per write) and the libmodbus peer server it is measured against.
MODBUS_LOAD := $(BUILD)/bench/modbus-load
MODBUS_PEER := $(BUILD)/bench/modbus-static-server
$(MODBUS_LOAD): bench/modbus_load.c
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) -o $@ $< -pthread $(LDFLAGS)
$(MODBUS_PEER): bench/modbus_static_server.c
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(MODBUS_CFLAGS) -o $@ $< $(MODBUS_LIBS) $(LDFLAGS)

.PHONY: bench-modbus
bench-modbus: all $(MODBUS_LOAD) $(MODBUS_PEER)
	sh bench/bench_modbus.sh $(BUILD)

# BENCH_QUICK=1 make bench: integration budgets up to 1e6 only.
BENCH_INT_DIMS := 2 5 10 20 30
bench: deps-bench all $(BENCH_BIN) $(QMC_LOAD) $(PIXELS_LOAD) $(MODBUS_LOAD) $(MODBUS_PEER)
	$(BUILD)/bench/bench_seq $(BUILD)/bench/seq.csv
	$(MAKE) --no-print-directory bench-charts-seq
	$(BUILD)/bench/bench_pixels $(BUILD)/bench | tee $(BUILD)/bench/pixels.txt
	$(MAKE) --no-print-directory bench-charts-pixels
	$(BUILD)/bench/bench_integrate $(BUILD)/bench | tee $(BUILD)/bench/integrate.txt
	$(MAKE) --no-print-directory bench-charts-integrate
	$(BUILD)/bench/bench_session | tee $(BUILD)/bench/session.txt
	$(BUILD)/bench/bench_session_wire $(QMCD) | tee $(BUILD)/bench/session_wire.txt
	/usr/bin/python3 bench/bench_command.py $(QMC) $(BUILD)/bench | tee $(BUILD)/bench/command.txt
	sh bench/bench_daemon.sh $(BUILD)
	sh bench/bench_pixels_remote.sh $(BUILD)
	sh bench/bench_python.sh $(BUILD)
	sh bench/bench_modbus.sh $(BUILD)

# Every chart twice, PNG and SVG side by side (each .gp script takes png=
# or svg=); these only draw, from the CSVs a bench run left in
# $(BUILD)/bench, so a chart can be redrawn without rerunning the bench.
.PHONY: bench-charts-seq bench-charts-integrate bench-charts-pixels
BENCH_OUT := $(BUILD)/bench
bench-charts-seq:
	@for k in png svg; do gnuplot -e "csv='$(BENCH_OUT)/seq.csv'; \
	  $$k='$(BENCH_OUT)/seq-rates.$$k'" bench/seq_rates.gp || exit 1; done
	@echo "charts: $(BENCH_OUT)/seq-rates.{png,svg}"
bench-charts-pixels:
	@for k in png svg; do gnuplot -e "dir='$(BENCH_OUT)'; \
	  $$k='$(BENCH_OUT)/pixels-error.$$k'" bench/pixels_error.gp || exit 1; done
	@echo "charts: $(BENCH_OUT)/pixels-error.{png,svg}"
bench-charts-integrate:
	@for k in png svg; do \
	  for d in 2 4 8; do gnuplot -e "csv='$(BENCH_OUT)/integrate-conv.csv'; d=$$d; \
	    $$k='$(BENCH_OUT)/integrate-conv-d$$d.$$k'" bench/integrate_conv.gp || exit 1; done; \
	  gnuplot -e "csv='$(BENCH_OUT)/integrate-gl.csv'; $$k='$(BENCH_OUT)/integrate-gl.$$k'" \
	    bench/integrate_gl.gp || exit 1; \
	  for d in $(BENCH_INT_DIMS); do gnuplot -e "csv='$(BENCH_OUT)/integrate-runs.csv'; \
	    d=$$d; $$k='$(BENCH_OUT)/integrate-time-d$$d.$$k'" bench/integrate_time.gp || exit 1; \
	  done; done
	@echo "charts: $(BENCH_OUT)/integrate-{conv-d*,gl,time-d*}.{png,svg}"

# ---- demo ------------------------------------------------------------------------
demo: deps-build deps-demo
	$(MAKE) all
	sh build-aux/demo.sh $(QMC) $(QMCD)

# ---- packages ----------------------------------------------------------------
deps-build:
	@sh build-aux/deps.sh build
deps-test: deps-build
	@sh build-aux/deps.sh test
deps-bench: deps-build
	@sh build-aux/deps.sh bench
deps-demo:
	@sh build-aux/deps.sh demo

# ---- install -----------------------------------------------------------------
# Everything an operator needs (docs/OPERATIONS.md): the programs, the
# libraries (static, and shared with its soname and symlinks), headers,
# qmcclient.pc and qmc.pc, man pages, the systemd units with this PREFIX's
# paths, the sysusers.d/tmpfiles.d snippets for the user qmcd, the client
# group qmc and /run/qmcd, the example config (never overwritten), bash
# completion.
# `make uninstall` removes the same files; a config that differs from the
# shipped example is left in place (and said so).
SYSCONFDIR  ?= /etc
BINDIR      ?= $(PREFIX)/bin
SBINDIR     ?= $(PREFIX)/sbin
LIBDIR      ?= $(PREFIX)/lib
INCLUDEDIR  ?= $(PREFIX)/include
MANDIR      ?= $(PREFIX)/share/man
DOCDIR      ?= $(PREFIX)/share/doc/qmcd
UNITDIR     ?= $(PREFIX)/lib/systemd/system
SYSUSERSDIR ?= $(PREFIX)/lib/sysusers.d
TMPFILESDIR ?= $(PREFIX)/lib/tmpfiles.d
BASHCOMPDIR ?= $(PREFIX)/share/bash-completion/completions
SO_VERSION  := 0.1.0
SO_NAME     := libqmcclient.so.0
D := $(DESTDIR)
INSTALL_DOCS := README.md NOTICE $(wildcard docs/*.md) protocol/PROTOCOL.md \
                protocol/MODBUS.md systemd/haproxy-qmcd.cfg

install: all
	install -d $(D)$(BINDIR) $(D)$(SBINDIR) $(D)$(LIBDIR)/pkgconfig $(D)$(INCLUDEDIR)/qmc \
	  $(D)$(MANDIR)/man1 $(D)$(MANDIR)/man5 $(D)$(MANDIR)/man8 $(D)$(DOCDIR) \
	  $(D)$(UNITDIR) $(D)$(SYSUSERSDIR) $(D)$(TMPFILESDIR) $(D)$(BASHCOMPDIR) \
	  $(D)$(SYSCONFDIR)/qmcd
	install -m 0755 $(QMC) $(D)$(BINDIR)/qmc
	install -m 0755 $(QMCD) $(D)$(SBINDIR)/qmcd
	install -m 0644 $(ALL_LIBS) $(D)$(LIBDIR)/
	install -m 0755 $(SOCLIENT) $(D)$(LIBDIR)/libqmcclient.so.$(SO_VERSION)
	ln -sf libqmcclient.so.$(SO_VERSION) $(D)$(LIBDIR)/$(SO_NAME)
	ln -sf $(SO_NAME) $(D)$(LIBDIR)/libqmcclient.so
	sed -e 's|@PREFIX@|$(PREFIX)|g' client/qmcclient.pc.in > $(D)$(LIBDIR)/pkgconfig/qmcclient.pc
	sed -e 's|@PREFIX@|$(PREFIX)|g' client/qmc.pc.in > $(D)$(LIBDIR)/pkgconfig/qmc.pc
	install -m 0644 include/qmc/*.h $(D)$(INCLUDEDIR)/qmc/
	install -m 0644 man/qmc.1 $(D)$(MANDIR)/man1/
	install -m 0644 man/qmcd.conf.5 $(D)$(MANDIR)/man5/
	install -m 0644 man/qmcd.8 $(D)$(MANDIR)/man8/
	install -m 0644 $(INSTALL_DOCS) $(D)$(DOCDIR)/
	sed -e 's|@SBINDIR@|$(SBINDIR)|g' -e 's|@SYSCONFDIR@|$(SYSCONFDIR)|g' \
	  systemd/qmcd.service > $(D)$(UNITDIR)/qmcd.service
	install -m 0644 systemd/qmcd.socket $(D)$(UNITDIR)/
	install -m 0644 systemd/qmcd-modbus-rtu.conf $(D)$(DOCDIR)/
	install -m 0644 systemd/sysusers-qmcd.conf $(D)$(SYSUSERSDIR)/qmcd.conf
	install -m 0644 systemd/tmpfiles-qmcd.conf $(D)$(TMPFILESDIR)/qmcd.conf
	install -m 0644 client/completion/qmc $(D)$(BASHCOMPDIR)/qmc
	install -m 0644 systemd/qmcd.conf $(D)$(DOCDIR)/qmcd.conf.example
	@if [ -e $(D)$(SYSCONFDIR)/qmcd/qmcd.conf ]; then \
	  echo "install: keeping the existing $(D)$(SYSCONFDIR)/qmcd/qmcd.conf"; \
	else install -m 0644 systemd/qmcd.conf $(D)$(SYSCONFDIR)/qmcd/qmcd.conf; fi

uninstall:
	rm -f $(D)$(BINDIR)/qmc $(D)$(SBINDIR)/qmcd
	rm -f $(addprefix $(D)$(LIBDIR)/,$(notdir $(ALL_LIBS)) libqmcclient.so \
	  $(SO_NAME) libqmcclient.so.$(SO_VERSION) pkgconfig/qmcclient.pc pkgconfig/qmc.pc)
	rm -f $(addprefix $(D)$(INCLUDEDIR)/qmc/,$(notdir $(wildcard include/qmc/*.h)))
	rm -f $(D)$(MANDIR)/man1/qmc.1 $(D)$(MANDIR)/man5/qmcd.conf.5 $(D)$(MANDIR)/man8/qmcd.8
	rm -f $(addprefix $(D)$(DOCDIR)/,$(notdir $(INSTALL_DOCS)) qmcd-modbus-rtu.conf \
	  qmcd.conf.example)
	rm -f $(D)$(UNITDIR)/qmcd.service $(D)$(UNITDIR)/qmcd.socket \
	  $(D)$(SYSUSERSDIR)/qmcd.conf $(D)$(TMPFILESDIR)/qmcd.conf $(D)$(BASHCOMPDIR)/qmc
	@c=$(D)$(SYSCONFDIR)/qmcd/qmcd.conf; \
	  if [ -e $$c ] && cmp -s $$c systemd/qmcd.conf; then rm -f $$c; \
	  elif [ -e $$c ]; then echo "uninstall: $$c was modified; left in place"; fi
	-rmdir $(D)$(INCLUDEDIR)/qmc $(D)$(DOCDIR) $(D)$(SYSCONFDIR)/qmcd 2>/dev/null

clean:
	rm -rf build

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
