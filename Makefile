# sqffd - build, test, bench, fuzz.   `make test` needs only a C compiler (cc) and make.
CC      ?= cc
# -g1: line tables for backtraces (gdb, valgrind); -g's variable records cost a quarter more build time
CFLAGS  ?= -O2 -g1
STRICT   = -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Werror
SAN      = -O1 -g -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
BUILD    = build
PREFIX  ?= /usr/local
# make test and make check run their parts JOBS at a time (unless make is given -j)
JOBS    ?= 2

# The unit-test binary: the core (tests/check_header.c, the file that defines SQFFD_IMPLEMENTATION)
# and every tests/test_*.c (test_main.c holds the runner), one object each.
UNIT_SRC = tests/check_header.c $(wildcard tests/test_*.c)
TEST_DEP = sqffd.h $(wildcard tests/*.h) $(wildcard examples/*.h)
FUZZ_TARGETS = $(patsubst fuzz/%.c,%,$(wildcard fuzz/fuzz_*.c))
BENCHES = $(patsubst bench/%.c,%,$(wildcard bench/bench_*.c))

TEST_PARTS  = unit check-header snippets cli-test api-demo
CHECK_PARTS = bench-build valgrind unit-asan unit-clang-asan fuzz-replay analyzer cppcheck threads stack check-symbols \
  package-test stream-test test-python $(TEST_PARTS)

.PHONY: bench-build all test check unit-build check-header check-symbols snippets cli-test readme-samples api-demo stream-test package-test unit unit-asan \
  unit-clang-asan valgrind analyzer cppcheck threads fuzz-replay demo bench fuzz install clean stack embedded test-cross

all: $(BUILD)/sqffd $(BUILD)/demo_fit $(BUILD)/stream_fit

$(BUILD):
	@mkdir -p $(BUILD)

$(BUILD)/sqffd: examples/sqffd_cli.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -o $@ examples/sqffd_cli.c -lm

# The API demo, built strict (it is the README's API tour as a program).
$(BUILD)/demo_fit: examples/demo_fit.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 $(STRICT) -o $@ examples/demo_fit.c -lm

# Fixed-memory streaming (the firmware pattern): one static buffer, frame 0 fitted, the rest tracked.
$(BUILD)/stream_fit: examples/stream_fit.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 $(STRICT) -o $@ examples/stream_fit.c -lm

# ---- make test (about a minute): the strictness matrix, the snippets, the unit tests at -O2, the CLI
# end to end, the API demo. make check: all of that, then the sanitizers, the fuzz corpora, symbols,
# packaging, streaming, Python, threads, valgrind, cppcheck, clang's analyzer and the stack bound.
# Both first build the command-line tool and the unit tests (make starts jobs in the order it meets
# them: the tool, the longest build, first), then run their parts JOBS at a time (the unit tests, the
# longest run, first), each part's output in one piece, and end with the unit-test runner's "N passed,
# N failed" line.
SUBMAKE = $(MAKE) --no-print-directory $(if $(filter -j%,$(MAKEFLAGS)),,-j$(JOBS)) \
  $(if $(filter output-sync,$(.FEATURES)),--output-sync=target)
PARTS = rm -f $(BUILD)/O2/unit.log; mkdir -p $(BUILD); $(SUBMAKE) $(BUILD)/sqffd unit-build && $(SUBMAKE) $(1); s=$$?; \
  tail -n 1 $(BUILD)/O2/unit.log 2>/dev/null; exit $$s
test:
	+@$(call PARTS,$(TEST_PARTS))
check: export SQFFD_TESTS_THOROUGH = 1
check:
	+@$(call PARTS,$(CHECK_PARTS))
unit-build: $(BUILD)/O2/sqffd_tests
	@:

# Flavours of the unit-test build, build/<flavour>/: the core compiled once into sqffd.o, each test
# file into its own object (dependencies from the compiler, -MMD). O0 is strict C99 at -O0: the
# core of the two-unit link and of the symbol check.
FLAVOURS = O2 O0 asan clang-asan
CC_O2 = $(CC)
CC_O0 = $(CC)
CC_asan = $(CC)
CC_clang-asan = clang
FLAGS_O2 = -O2 -g1 -Wall -Wextra
# The O2 flavour's test files at -O1: their own code is not what is measured (the core, sqffd.o, is -O2);
# they build in 60 % of the time and the runner takes 2 s more.
TEST_OPT_O2 = -O1
FLAGS_O0 = -O0 $(STRICT)
FLAGS_asan = $(SAN) -Wall -Wextra
FLAGS_clang-asan = $(SAN) -Wall -Wextra
define FLAVOUR
$(BUILD)/$(1)/sqffd.o: tests/check_header.c
	@mkdir -p $$(@D)
	$(CC_$(1)) $(FLAGS_$(1)) -std=c99 -MMD -MP -c $$< -o $$@
$(BUILD)/$(1)/%.o: tests/%.c
	@mkdir -p $$(@D)
	$(CC_$(1)) $(FLAGS_$(1)) $(TEST_OPT_$(1)) -std=c99 -MMD -MP -c $$< -o $$@
$(BUILD)/$(1)/sqffd_tests: $(BUILD)/$(1)/sqffd.o $(patsubst tests/%.c,$(BUILD)/$(1)/%.o,$(wildcard tests/test_*.c))
	$(CC_$(1)) $(FLAGS_$(1)) -o $$@ $$^ -lm
endef
$(foreach f,$(FLAVOURS),$(eval $(call FLAVOUR,$(f))))
-include $(wildcard $(BUILD)/*/*.d)

# $(call RUN_UNIT,BINARY,DIR[,WRAPPER[,ARGS]]): the runner with DIR as its working directory (the tests
# write scratch files there; tests/data is reached through a link), its output in DIR/unit.log.
RUN_UNIT = mkdir -p $(2) && ln -sfn $(CURDIR)/tests $(2)/tests && (cd $(2) && $(3) $(CURDIR)/$(1) $(4)) > $(2)/unit.log 2>&1
# ... then one status line TITLE: N passed, N failed (the log's end when it fails)
UNIT_STATUS = { $(call RUN_UNIT,$(1),$(2),$(4)) && tail -n 1 $(2)/unit.log | sed 's/^/$(3): /'; } \
  || { tail -n 30 $(2)/unit.log; exit 1; }

# Two runners at once, every other case each (--shard), each in its own directory; unit.log holds both
# logs, their "N passed, N failed" lines summed into one.
unit: $(BUILD)/O2/sqffd_tests
	@echo "== unit tests (-O2, two shards)"; \
	{ $(call RUN_UNIT,$<,$(BUILD)/O2/shard1,,--shard 1/2); } & other=$$!; \
	$(call RUN_UNIT,$<,$(BUILD)/O2/shard0,,--shard 0/2); s=$$?; wait $$other || s=1; \
	cat $(BUILD)/O2/shard0/unit.log $(BUILD)/O2/shard1/unit.log | awk '/^[0-9]+ passed, [0-9]+ failed$$/ { p += $$1; f += $$3; next } \
	  { print } END { printf "%d passed, %d failed\n", p, f }' > $(BUILD)/O2/unit.log; cat $(BUILD)/O2/unit.log; exit $$s

unit-asan: $(BUILD)/asan/sqffd_tests
	@$(call UNIT_STATUS,$<,$(BUILD)/asan,unit tests ($(CC) address+undefined sanitizers))

# clang's sanitizers, when its runtime is installed.
unit-clang-asan:
	@printf 'int main(void) { return 0; }\n' > $(BUILD)/probe.c; \
	if ! command -v clang >/dev/null 2>&1; then echo "check: clang not installed, clang sanitizers skipped"; \
	elif ! clang -fsanitize=address,undefined $(BUILD)/probe.c -o $(BUILD)/probe 2>/dev/null; then \
	  echo "check: clang has no sanitizer runtime (Debian: libclang-rt-dev), clang sanitizers skipped"; \
	else $(MAKE) --no-print-directory -s $(BUILD)/clang-asan/sqffd_tests && \
	  $(call UNIT_STATUS,$(BUILD)/clang-asan/sqffd_tests,$(BUILD)/clang-asan,clang address+undefined sanitizers); fi

valgrind: $(BUILD)/O2/sqffd_tests
	@if command -v valgrind >/dev/null 2>&1; then \
	  $(call UNIT_STATUS,$<,$(BUILD)/valgrind,valgrind,valgrind -q --error-exitcode=1 --leak-check=full); \
	else echo "check: valgrind not installed, skipped"; fi

# The strictness matrix: sqffd.h as C99 and C11 ($(CC), and clang when present) and C++11 (g++ and
# clang++ when present), strict warnings as errors, -fsyntax-only where no object is needed; two
# translation units linked (tests/check_use.c against the core, in C and in C++); an SQFFD_STATIC
# build; a unit built with another SQFFD_MAX_LATTICE fails to link against the core, and so does each
# public function that depends on it, alone (tests/check_lattice_guard.sh, from the header's declarations).
check-header: $(BUILD)/O0/sqffd.o
	@o=$(BUILD)/O0; set -e; \
	$(CC) -std=c99 $(STRICT) -c tests/check_use.c -o $$o/check_use.o; \
	$(CC) $$o/sqffd.o $$o/check_use.o -o $$o/check_link -lm; \
	$(CC) -std=c99 $(STRICT) -Wno-unused-function -DSQFFD_STATIC tests/check_use.c -o $$o/check_static -lm; \
	for f in tests/check_header.c tests/check_use.c "-Wno-unused-function -DSQFFD_STATIC tests/check_use.c"; do \
	  $(CC) -std=c11 $(STRICT) -fsyntax-only $$f; done; \
	$(CC) -std=c99 -DSQFFD_MAX_LATTICE=6 -c tests/check_use.c -o $$o/check_use_lattice6.o; \
	if $(CC) $$o/sqffd.o $$o/check_use_lattice6.o -o $$o/check_lattice_mix -lm 2>/dev/null; then \
	  echo "check-header: units built with SQFFD_MAX_LATTICE 6 and 8 linked together"; exit 1; fi; \
	sh tests/check_lattice_guard.sh $(CC) $$o/sqffd.o $(BUILD)/lattice_guard; \
	cc="$(CC)"; if command -v clang >/dev/null 2>&1; then cc="$$cc, clang"; \
	  for std in c99 c11; do clang -std=$$std $(STRICT) -fsyntax-only tests/check_header.c; done; fi; \
	cxx=""; for c in g++ clang++; do command -v $$c >/dev/null 2>&1 || continue; \
	  $$c -x c++ -std=c++11 $(STRICT) -fsyntax-only tests/check_header.c; \
	  if [ -z "$$cxx" ]; then $$c -x c++ -std=c++11 $(STRICT) -c tests/check_use.c -o $$o/check_use_cxx.o; \
	    $$c $$o/sqffd.o $$o/check_use_cxx.o -o $$o/check_link_cxx -lm; cxx=$$c; else cxx="$$cxx, $$c"; fi; \
	done; \
	[ -n "$$cxx" ] || echo "check-header: no C++ compiler (g++ or clang++), C++ checks skipped"; \
	echo "header: C99/C11 ($$cc)$${cxx:+, C++11 ($$cxx)}, two TUs, SQFFD_STATIC, lattice mismatch fails to link: clean"

# Every code snippet of README.md and sqffd.h, extracted from them (tests/snippets.sh says what counts
# as one and how it is wrapped), compiled strict against the header.
$(BUILD)/snippets.c: tests/snippets.sh README.md sqffd.h | $(BUILD)
	@sh tests/snippets.sh README.md sqffd.h > $@
# Then the header's API BY LAYER list against its declarations (tests/check_doc_names.sh).
snippets: $(BUILD)/snippets.c tests/snippets.h
	@$(CC) -std=c99 $(filter-out -Wshadow,$(STRICT)) -Itests -fsyntax-only $< \
	  && echo "snippets: the $$(grep -c '^#line' $<) code snippets of README.md and sqffd.h compile" \
	  && sh tests/check_doc_names.sh sqffd.h

# The core object may reference libm, memcpy/memset/memmove and assert only,
# and may define no writable globals: at -O2 and at -O0 (no inlining, no
# builtins folded away: every call the code makes shows).
check-symbols: $(BUILD)/O2/sqffd.o $(BUILD)/O0/sqffd.o
	@bad=0; for o in O2 O0; do \
	  out=$$(sh tests/check_symbols.sh $(BUILD)/$$o/sqffd.o) || bad=1; \
	  echo "$$out" | sed "s/^\([a-z-]*\):/\1 (-$$o):/"; \
	done; exit $$bad

# End-to-end checks of the command-line tool (exit codes, messages, output files), then README.md's
# sample outputs against what the programs print (tests/readme_samples.sh; timings masked).
# make readme-samples rewrites those samples from the programs' output.
cli-test: $(BUILD)/sqffd $(BUILD)/stream_fit
	@sh tests/cli_test.sh $(BUILD)/sqffd && sh tests/readme_samples.sh $(BUILD) README.md

readme-samples: $(BUILD)/sqffd $(BUILD)/stream_fit
	@sh tests/readme_samples.sh --write $(BUILD) README.md

api-demo: $(BUILD)/demo_fit
	@./$(BUILD)/demo_fit > $(BUILD)/demo_fit.log && echo "api demo: fit, report, model point and mesh: ok" \
	  || { cat $(BUILD)/demo_fit.log; exit 1; }

# make install into a temporary DESTDIR, then a tiny consumer built with pkg-config
# and (when cmake is present) through add_subdirectory, FetchContent and find_package.
package-test: $(BUILD)/sqffd $(BUILD)/demo_fit
	@sh tests/package_test.sh

# stream_fit on a phantom sequence written by the CLI: the same models as 'sqffd track', bad frames skipped.
stream-test: $(BUILD)/sqffd $(BUILD)/stream_fit
	@sh tests/stream_test.sh $(BUILD)/sqffd $(BUILD)/stream_fit

# ---- make shared: build/libsqffd.so, for the Python module (examples/python/sqffd.py) and
# other languages' FFIs; it must export the sqffd_ functions and nothing else.
.PHONY: shared test-python bench-python
$(BUILD)/libsqffd.so: examples/python/sqffd_shared.c sqffd.h | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -fPIC -shared -o $@ examples/python/sqffd_shared.c -lm

shared: $(BUILD)/libsqffd.so
	@bad=$$(nm -D --defined-only $< | awk '{print $$NF}' | grep -v '^sqffd_[a-z]'); \
	if [ -n "$$bad" ]; then echo "shared: $< exports more than the sqffd_ functions:" $$bad; exit 1; fi; \
	echo "shared: $< exports $$(nm -D --defined-only $< | wc -l) symbols, all sqffd_ functions"

# A python3 with numpy: $(PYTHON) when given, else python3, else /usr/bin/python3 (prints nothing when none has it).
NUMPY_PYTHON = for p in $(PYTHON) python3 /usr/bin/python3; do "$$p" -c 'import numpy' >/dev/null 2>&1 && { echo "$$p"; break; }; done

$(BUILD)/python_layout: tests/python/layout.c sqffd.h | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -o $@ tests/python/layout.c

$(BUILD)/python_reference: tests/python/reference.c sqffd.h examples/sqffd_phantom.h $(BUILD)/libsqffd.so
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -o $@ tests/python/reference.c -L$(BUILD) -lsqffd -Wl,-rpath,'$$ORIGIN' -lm

# The Python module against the C library (tests/python/test_sqffd.py); skipped without numpy.
test-python: | $(BUILD)
	@py=$$($(NUMPY_PYTHON)); \
	if [ -z "$$py" ]; then echo "test-python: skipped, no python3 with numpy (Debian: apt-get install python3-numpy)"; exit 0; fi; \
	$(MAKE) --no-print-directory -s shared $(BUILD)/python_layout $(BUILD)/python_reference \
	  && "$$py" tests/python/test_sqffd.py $(BUILD)

# Every fuzz target replays its seed corpus under the sanitizers (gcc, no libFuzzer).
$(BUILD)/replay_%: fuzz/%.c fuzz/replay.c $(TEST_DEP) $(wildcard fuzz/*.h) | $(BUILD)
	$(CC) $(SAN) -std=c99 -Wall -Wextra -o $@ $< fuzz/replay.c -lm

fuzz-replay: $(addprefix $(BUILD)/replay_,$(FUZZ_TARGETS))
	@for t in $(FUZZ_TARGETS); do ./$(BUILD)/replay_$$t fuzz/corpus/$$t || exit 1; done

# clang's static analyzer on the implementation (any report fails; -analyze-headers: the code is in
# sqffd.h, which the analyzer otherwise skips).
analyzer: | $(BUILD)
	@if command -v clang >/dev/null 2>&1; then \
	  clang --analyze -std=c99 -Xanalyzer -analyzer-opt-analyze-headers -Xanalyzer -analyzer-output=text \
	    tests/check_header.c -o /dev/null > $(BUILD)/analyzer.log 2>&1 || { cat $(BUILD)/analyzer.log; exit 1; }; \
	  if grep -q 'warning:' $(BUILD)/analyzer.log; then grep 'warning:' $(BUILD)/analyzer.log; \
	    echo "clang analyzer: $$(grep -c 'warning:' $(BUILD)/analyzer.log) reports (their paths: $(BUILD)/analyzer.log)"; exit 1; fi; \
	  echo "clang analyzer: sqffd.h with its implementation: no reports"; \
	else echo "check: clang not installed, static analysis skipped"; fi

# Concurrent fits under ThreadSanitizer (tests/check_threads.c), with clang or gcc, whichever works.
threads: | $(BUILD)
	@printf 'int main(void) { return 0; }\n' > $(BUILD)/probe_tsan.c; \
	tsan=""; for c in clang gcc; do \
	  command -v $$c >/dev/null 2>&1 && $$c -fsanitize=thread $(BUILD)/probe_tsan.c -o $(BUILD)/probe_tsan 2>/dev/null \
	    && ./$(BUILD)/probe_tsan >/dev/null 2>&1 && { tsan=$$c; break; }; \
	done; \
	if [ -z "$$tsan" ]; then echo "check: no compiler with a working ThreadSanitizer (clang or gcc), thread check skipped"; \
	else \
	  $$tsan -std=c99 -O1 -g -fsanitize=thread -Wall -Wextra -o $(BUILD)/check_threads tests/check_threads.c tests/test_util.c -lm -pthread || exit 1; \
	  ./$(BUILD)/check_threads > $(BUILD)/check_threads.log 2>&1 \
	    && sed "s/^threads:/threads ($$tsan -fsanitize=thread):/" $(BUILD)/check_threads.log || { cat $(BUILD)/check_threads.log; exit 1; }; \
	fi

# legacyUninitvar is off: it flags output arrays passed to a function that fills them.
cppcheck:
	@if command -v cppcheck >/dev/null 2>&1; then \
	  cppcheck --enable=warning,performance,portability --std=c99 --suppress=legacyUninitvar --quiet \
	    --error-exitcode=1 -DSQFFD_IMPLEMENTATION tests/check_header.c && echo "cppcheck: clean"; \
	else echo "check: cppcheck not installed, skipped"; fi

# ---- make stack: the worst-case stack from gcc's call graph (-fcallgraph-info, GCC >= 10),
# x86-64 at -O2 and -Os: every frame <= 2048 bytes, sqffd_fit and sqffd_track <= 8192
# bytes, no recursion, no unbounded dynamic frame (tests/stack_bound.c; -v: every
# frame). The objective, projection and progress the superquadric's CG hands to
# sqffd_ncg_minimize are named here; the user's callbacks come on top of the bound.
STACK_CC ?= gcc
STACK_FLAGS = --frame-limit 2048 --stack-limit 8192 --root sqffd_fit --root sqffd_track --public sqffd_ \
  --indirect sqffd_ncg_minimize=sqffd__sq_cg_objective,sqffd__sq_cg_project,sqffd__sq_cg_progress,user
$(BUILD)/stack/stack_bound: tests/stack_bound.c
	@mkdir -p $(BUILD)/stack
	$(STACK_CC) -O2 -std=c99 -Wall -Wextra -o $@ tests/stack_bound.c

stack: $(BUILD)/stack/stack_bound
	@fail=0; for o in O2 Os; do \
	  $(STACK_CC) -std=c99 -$$o -fcallgraph-info=su -fstack-usage -c tests/check_header.c -o $(BUILD)/stack/core_$$o.o || exit 1; \
	  ./$(BUILD)/stack/stack_bound -v $(STACK_FLAGS) --title "stack, x86-64 $(STACK_CC) -$$o" $(BUILD)/stack/core_$$o.ci > $(BUILD)/stack/report_$$o.txt; \
	  ./$(BUILD)/stack/stack_bound --brief $(STACK_FLAGS) --title "stack, x86-64 $(STACK_CC) -$$o" $(BUILD)/stack/core_$$o.ci || fail=1; \
	done; \
	[ $$fail -eq 0 ] || echo "stack: limits broken (every frame and chain: $(BUILD)/stack/report_O2.txt, report_Os.txt)"; exit $$fail

# ---- make embedded: the core cross-compiled for Cortex-M7 (arm-none-eabi-gcc, newlib;
# installed with apt-get when missing): only libm and the listed helpers needed,
# .text <= 64 KB, a firmware-style fit links (and runs under qemu-arm when present),
# the stack limits above on the Cortex-M7 call graph.
embedded: $(BUILD)/stack/stack_bound
	@sh tests/embedded/embedded.sh $(BUILD) ./$(BUILD)/stack/stack_bound $(STACK_FLAGS)

# ---- make test-cross: the unit tests on 32-bit ARM and big-endian s390x under qemu-user
# (cross compilers and qemu installed with apt-get when missing; skipped when impossible).
test-cross: | $(BUILD)
	@sh tests/cross_test.sh $(BUILD) $(UNIT_SRC)

# ---- make fuzz: libFuzzer (clang) on each target, FUZZ_SECONDS each
# (FUZZ_FLAGS adds libFuzzer options, e.g. -seed=1 for a repeatable run)
FUZZ_SECONDS ?= 60
FUZZ_FLAGS ?=
fuzz: | $(BUILD)
	@command -v clang >/dev/null 2>&1 || { echo "fuzz: clang not installed, skipped"; exit 0; }; \
	printf 'int LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n) { (void)d; (void)n; return 0; }\n' > $(BUILD)/fuzz_probe.c; \
	clang -fsanitize=fuzzer $(BUILD)/fuzz_probe.c -o $(BUILD)/fuzz_probe 2>/dev/null \
	  || { echo "fuzz: clang has no libFuzzer runtime (Debian: libclang-rt-dev), skipped"; exit 0; }; \
	for t in $(FUZZ_TARGETS); do \
	  clang -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -o $(BUILD)/libfuzzer_$$t fuzz/$$t.c -lm || exit 1; \
	  mkdir -p $(BUILD)/corpus_$$t; \
	  ./$(BUILD)/libfuzzer_$$t -max_total_time=$(FUZZ_SECONDS) -max_len=65536 $$(test -f fuzz/$$t.dict && echo -dict=fuzz/$$t.dict) $(FUZZ_FLAGS) $(BUILD)/corpus_$$t fuzz/corpus/$$t || exit 1; \
	done

# ---- make demo: the embedded default run of the command-line tool
demo: $(BUILD)/sqffd
	./$(BUILD)/sqffd demo -o $(BUILD)/demo

# ---- make bench: medians of repeated runs, peers where installable (nanoflann built with
# -ffp-contract=off: the C side is ISO C99, which fuses no a * b + c, so both sum the same distances)
BENCH_CFLAGS = -O2 -march=native -std=c99 -D_POSIX_C_SOURCE=200809L -Wall -Wextra

# Every bench compiles against today's header (make check; they are run by make bench only).
bench-build:
	@for b in $(BENCHES); do $(CC) $(BENCH_CFLAGS) -Werror -fsyntax-only bench/$$b.c || exit 1; done; \
	  echo "bench-build: $(words $(BENCHES)) benches compile"
bench: $(BUILD)/sqffd | $(BUILD)
	@sh bench/install_peers.sh
	@for b in $(BENCHES); do \
	  extra=""; link="$(CC)"; \
	  if [ $$b = bench_kdtree ] && [ -f /usr/include/nanoflann.hpp ]; then \
	    g++ -O2 -march=native -ffp-contract=off -std=c++14 -c bench/peer_nanoflann.cpp -o $(BUILD)/peer_nanoflann.o || exit 1; \
	    extra="-DSQFFD_BENCH_NANOFLANN $(BUILD)/peer_nanoflann.o"; link="g++ -x none"; fi; \
	  if [ $$b = bench_linalg ] && [ -f /usr/include/lapacke.h ]; then extra="-DSQFFD_BENCH_LAPACKE -llapacke"; fi; \
	  if [ $$b = bench_inflate ] && [ -f /usr/include/zlib.h ]; then extra="-DSQFFD_BENCH_ZLIB -lz"; fi; \
	  $(CC) $(BENCH_CFLAGS) -c bench/$$b.c -o $(BUILD)/$$b.o $$(echo $$extra | grep -o -- '-DSQFFD_BENCH_[A-Z]*') || exit 1; \
	  $$link $(BUILD)/$$b.o $$(echo $$extra | sed 's/-DSQFFD_BENCH_[A-Z]*//') -o $(BUILD)/$$b -lm || exit 1; \
	  ./$(BUILD)/$$b || exit 1; \
	done
	@$(MAKE) --no-print-directory bench-python

# The Python module's calling overhead against the same fit in C (bench/bench_python.py); skipped without numpy.
$(BUILD)/python_timer.so: bench/python_timer.c bench/bench.h examples/sqffd_phantom.h $(BUILD)/libsqffd.so
	$(CC) $(BENCH_CFLAGS) -Wno-unused-function -fPIC -shared -o $@ bench/python_timer.c -L$(BUILD) -lsqffd -Wl,-rpath,'$$ORIGIN' -lm

bench-python: | $(BUILD)
	@py=$$($(NUMPY_PYTHON)); \
	if [ -z "$$py" ]; then echo "bench_python: skipped, no python3 with numpy (Debian: apt-get install python3-numpy)"; exit 0; fi; \
	$(MAKE) --no-print-directory -s $(BUILD)/python_timer.so && "$$py" bench/bench_python.py $(BUILD)

# The paths are quoted: PREFIX and DESTDIR may hold blanks (not a single quote). sqffd.pc writes the
# prefix's blanks escaped (prefix=/opt/my\ tools), as pkg-config reads and prints them.
install: $(BUILD)/sqffd $(BUILD)/demo_fit
	install -d '$(DESTDIR)$(PREFIX)/include' '$(DESTDIR)$(PREFIX)/bin' '$(DESTDIR)$(PREFIX)/lib/pkgconfig'
	install -m 644 sqffd.h '$(DESTDIR)$(PREFIX)/include/sqffd.h'
	install -m 755 $(BUILD)/sqffd '$(DESTDIR)$(PREFIX)/bin/sqffd'
	@printf 'prefix=%s\nincludedir=$${prefix}/include\n\nName: sqffd\nDescription: %s\nVersion: %s\nCflags: -I$${includedir}\nLibs: -lm\n' \
	  "$$(printf '%s' '$(PREFIX)' | sed 's/ /\\ /g')" 'Superquadric + free-form deformation shape model (single header)' \
	  "$$(sed -n 's/^#define SQFFD_VERSION_STRING "\(.*\)"$$/\1/p' sqffd.h)" > $(BUILD)/sqffd.pc
	install -m 644 $(BUILD)/sqffd.pc '$(DESTDIR)$(PREFIX)/lib/pkgconfig/sqffd.pc'

clean:
	rm -rf $(BUILD)
