# sqffd - build, test, bench, fuzz.   `make test` needs only gcc and make.
CC      ?= cc
CFLAGS  ?= -O2 -g
STRICT   = -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Werror
SAN      = -O1 -g -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
BUILD    = build
PREFIX  ?= /usr/local

TEST_SRC = $(filter-out tests/test_main.c tests/test_impl.c,$(wildcard tests/test_*.c))
TEST_DEP = sqffd.h $(wildcard tests/*.h) $(wildcard examples/*.h)
FUZZ_TARGETS = $(patsubst fuzz/%.c,%,$(wildcard fuzz/fuzz_*.c))
BENCHES = $(patsubst bench/%.c,%,$(wildcard bench/bench_*.c))

.PHONY: all test check check-header check-symbols cli-test api-demo unit unit-asan fuzz-replay demo bench fuzz install clean

all: $(BUILD)/sqffd $(BUILD)/demo_fit

$(BUILD):
	@mkdir -p $(BUILD)

$(BUILD)/sqffd: examples/sqffd_cli.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -o $@ examples/sqffd_cli.c -lm

# The API demo, built strict (it is the README's API tour as a program).
$(BUILD)/demo_fit: examples/demo_fit.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 $(STRICT) -o $@ examples/demo_fit.c -lm

# ---- make test: header checks, symbol check, fuzz corpus replay, unit tests twice
test: check-header check-symbols fuzz-replay cli-test api-demo unit unit-asan

# The header as C99/C11 (gcc, and clang when present) and C++ (g++, clang++),
# strict warnings as errors; two translation units; an SQFFD_STATIC build.
check-header: | $(BUILD)
	@for std in c99 c11; do \
	  $(CC) -std=$$std $(STRICT) -c tests/check_header.c -o $(BUILD)/check_$$std.o || exit 1; \
	  $(CC) -std=$$std $(STRICT) -c tests/check_use.c -o $(BUILD)/check_use_$$std.o || exit 1; \
	  $(CC) $(BUILD)/check_$$std.o $(BUILD)/check_use_$$std.o -o $(BUILD)/check_link_$$std -lm || exit 1; \
	  $(CC) -std=$$std $(STRICT) -Wno-unused-function -DSQFFD_STATIC tests/check_use.c -o $(BUILD)/check_static_$$std -lm || exit 1; \
	done
	@g++ -x c++ -std=c++11 $(STRICT) -c tests/check_header.c -o $(BUILD)/check_cxx.o
	@g++ -x c++ -std=c++11 $(STRICT) -c tests/check_use.c -o $(BUILD)/check_use_cxx.o && g++ $(BUILD)/check_cxx.o $(BUILD)/check_use_cxx.o -o $(BUILD)/check_link_cxx -lm
	@if command -v clang >/dev/null 2>&1; then \
	  for std in c99 c11; do clang -std=$$std $(STRICT) -c tests/check_header.c -o $(BUILD)/check_clang_$$std.o || exit 1; done; \
	  clang++ -x c++ -std=c++11 $(STRICT) -c tests/check_header.c -o $(BUILD)/check_clangxx.o || exit 1; \
	  echo "header: C99/C11 (gcc, clang), C++11 (g++, clang++), two TUs, SQFFD_STATIC: clean"; \
	else echo "header: C99/C11 (gcc), C++11 (g++), two TUs, SQFFD_STATIC: clean; clang not installed, its checks skipped"; fi

# The core object may reference libm, memcpy/memset/memmove and assert only,
# and may define no writable globals.
check-symbols: | $(BUILD)
	@$(CC) -std=c99 -O2 -c tests/check_header.c -o $(BUILD)/core.o
	@sh tests/check_symbols.sh $(BUILD)/core.o

$(BUILD)/sqffd_tests: $(TEST_SRC) tests/test_main.c tests/test_impl.c $(TEST_DEP) | $(BUILD)
	$(CC) $(CFLAGS) -std=c99 -Wall -Wextra -o $@ tests/test_main.c tests/test_impl.c $(TEST_SRC) -lm

$(BUILD)/sqffd_tests_asan: $(TEST_SRC) tests/test_main.c tests/test_impl.c $(TEST_DEP) | $(BUILD)
	$(CC) $(SAN) -std=c99 -Wall -Wextra -o $@ tests/test_main.c tests/test_impl.c $(TEST_SRC) -lm

# End-to-end checks of the command-line tool (exit codes, messages, output files).
cli-test: $(BUILD)/sqffd
	@sh tests/cli_test.sh $(BUILD)/sqffd

api-demo: $(BUILD)/demo_fit
	@./$(BUILD)/demo_fit > $(BUILD)/demo_fit.log && echo "api demo: fit, report, model point and mesh: ok" \
	  || { cat $(BUILD)/demo_fit.log; exit 1; }

unit: $(BUILD)/sqffd_tests
	@echo "== unit tests (-O2)"
	@./$(BUILD)/sqffd_tests

unit-asan: $(BUILD)/sqffd_tests_asan
	@echo "== unit tests (address + undefined sanitizers)"
	@./$(BUILD)/sqffd_tests_asan

# Every fuzz target replays its seed corpus under the sanitizers (gcc, no libFuzzer).
$(BUILD)/replay_%: fuzz/%.c fuzz/replay.c $(TEST_DEP) | $(BUILD)
	$(CC) $(SAN) -std=c99 -Wall -Wextra -o $@ $< fuzz/replay.c -lm

fuzz-replay: $(addprefix $(BUILD)/replay_,$(FUZZ_TARGETS))
	@for t in $(FUZZ_TARGETS); do ./$(BUILD)/replay_$$t fuzz/corpus/$$t || exit 1; done

# ---- make check: make test, then static analysis and valgrind (skipped when missing).
# legacyUninitvar is off: it flags output arrays passed to a function that fills them.
check: test
	@if command -v cppcheck >/dev/null 2>&1; then \
	  cppcheck --enable=warning,performance,portability --std=c99 --suppress=legacyUninitvar --quiet \
	    --error-exitcode=1 -DSQFFD_IMPLEMENTATION tests/check_header.c && echo "cppcheck: clean"; \
	else echo "check: cppcheck not installed, skipped"; fi
	@if command -v valgrind >/dev/null 2>&1; then \
	  valgrind -q --error-exitcode=1 --leak-check=full ./$(BUILD)/sqffd_tests > $(BUILD)/valgrind.log 2>&1 \
	    && tail -n 1 $(BUILD)/valgrind.log | sed 's/^/valgrind: /' || { tail -n 30 $(BUILD)/valgrind.log; exit 1; }; \
	else echo "check: valgrind not installed, skipped"; fi

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
	  clang -g -O1 -fsanitize=fuzzer,address,undefined -o $(BUILD)/libfuzzer_$$t fuzz/$$t.c -lm || exit 1; \
	  mkdir -p $(BUILD)/corpus_$$t; \
	  ./$(BUILD)/libfuzzer_$$t -max_total_time=$(FUZZ_SECONDS) -max_len=65536 $(FUZZ_FLAGS) $(BUILD)/corpus_$$t fuzz/corpus/$$t || exit 1; \
	done

# ---- make demo: the embedded default run of the command-line tool
demo: $(BUILD)/sqffd
	./$(BUILD)/sqffd demo -o $(BUILD)/demo

# ---- make bench: medians of repeated runs, peers where installable
BENCH_CFLAGS = -O2 -march=native -std=c99 -D_POSIX_C_SOURCE=200809L -Wall -Wextra
bench: $(BUILD)/sqffd | $(BUILD)
	@sh bench/install_peers.sh
	@for b in $(BENCHES); do \
	  extra=""; link="$(CC)"; \
	  if [ $$b = bench_kdtree ] && [ -f /usr/include/nanoflann.hpp ]; then \
	    g++ -O2 -march=native -std=c++14 -c bench/peer_nanoflann.cpp -o $(BUILD)/peer_nanoflann.o || exit 1; \
	    extra="-DSQFFD_BENCH_NANOFLANN $(BUILD)/peer_nanoflann.o"; link="g++ -x none"; fi; \
	  if [ $$b = bench_linalg ] && [ -f /usr/include/lapacke.h ]; then extra="-DSQFFD_BENCH_LAPACKE -llapacke"; fi; \
	  if [ $$b = bench_inflate ] && [ -f /usr/include/zlib.h ]; then extra="-DSQFFD_BENCH_ZLIB -lz"; fi; \
	  $(CC) $(BENCH_CFLAGS) -c bench/$$b.c -o $(BUILD)/$$b.o $$(echo $$extra | grep -o -- '-DSQFFD_BENCH_[A-Z]*') || exit 1; \
	  $$link $(BUILD)/$$b.o $$(echo $$extra | sed 's/-DSQFFD_BENCH_[A-Z]*//') -o $(BUILD)/$$b -lm || exit 1; \
	  ./$(BUILD)/$$b || exit 1; \
	done

install: $(BUILD)/sqffd $(BUILD)/demo_fit
	install -d $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/bin
	install -m 644 sqffd.h $(DESTDIR)$(PREFIX)/include/sqffd.h
	install -m 755 $(BUILD)/sqffd $(DESTDIR)$(PREFIX)/bin/sqffd

clean:
	rm -rf $(BUILD)
