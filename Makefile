# sph: build, test, clean.  Objects and module files go to $(BUILD); the
# executable is ./sph.  Dependencies between modules are read from the `use`
# statements (file name = module name), so the order is automatic.

FC      ?= mpifort
FC      := mpifort
PYTHON  ?= /usr/bin/python3
BUILD   ?= build/release
NP_TEST ?= 1 2 3

HDF5_INC := /usr/include/hdf5/openmpi
HDF5_LIB := /usr/lib/x86_64-linux-gnu/hdf5/openmpi

# -march=native: the code is always compiled on the machine that runs it
# (README, CI); it enables AVX2/FMA on these machines.  No -ffast-math: NaN
# detection and run-to-run reproducibility rely on IEEE semantics.
OPTFLAGS ?= -O3 -march=native
WFLAGS   := -std=f2018 -Wall -Wextra -Wimplicit-interface -fimplicit-none
FFLAGS   := $(OPTFLAGS) $(WFLAGS) -J$(BUILD) -I$(BUILD) -I$(HDF5_INC) -I/usr/include
LDLIBS   := -L$(HDF5_LIB) -Wl,-rpath,$(HDF5_LIB) -lhdf5_fortran -lhdf5 -lfftw3 -lmetis

# EXCLUDE (file names without .f90) leaves work in progress out of a build.
EXCLUDE   ?=
SRC       := $(filter-out $(patsubst %,src/%.f90,$(EXCLUDE)),$(wildcard src/*.f90))
LIB_SRC   := $(filter-out src/main.f90,$(SRC))
SUITES    := $(filter-out $(patsubst test_%,%,$(EXCLUDE)),\
               $(patsubst tests/unit/test_%.f90,%,$(wildcard tests/unit/test_*.f90)))
TEST_SRC  := tests/testing.f90 $(patsubst %,tests/unit/test_%.f90,$(SUITES))

LIB_OBJ   := $(patsubst src/%.f90,$(BUILD)/%.o,$(LIB_SRC))
TEST_OBJ  := $(patsubst %.f90,$(BUILD)/%.o,$(notdir $(TEST_SRC)))
RUNNER    := $(BUILD)/run_unit_tests.f90

vpath %.f90 src tests tests/unit

.PHONY: all sph debug test unit bench validate clean
all: sph

# copy then rename: replaces ./sph atomically, even while it is running
sph: $(BUILD)/sph
	cp $< $@.tmp && mv -f $@.tmp $@

$(BUILD)/sph: $(LIB_OBJ) $(BUILD)/main.o
	$(FC) $(FFLAGS) -o $@ $^ $(LDLIBS)

$(BUILD)/%.o: %.f90 | $(BUILD)
	$(FC) $(FFLAGS) -c $< -o $@

$(BUILD):
	mkdir -p $@

# Module dependencies: "use foo" in any source makes its object depend on
# $(BUILD)/foo.o when foo is one of ours.
$(BUILD)/deps.mk: $(SRC) $(TEST_SRC) | $(BUILD)
	@for f in $(SRC) $(TEST_SRC); do \
	  o=$(BUILD)/$$(basename $$f .f90).o; \
	  for m in $$(sed -nE 's/^[[:space:]]*use[[:space:]]*(,[[:space:]]*non_intrinsic[[:space:]]*::)?[[:space:]]*([A-Za-z0-9_]+).*/\2/Ip' $$f | tr A-Z a-z | sort -u); do \
	    for d in src tests tests/unit; do \
	      if [ -f $$d/$$m.f90 ] && [ $$m != $$(basename $$f .f90) ]; then echo "$$o: $(BUILD)/$$m.o"; fi; \
	    done; \
	  done; \
	done > $@
-include $(BUILD)/deps.mk

# The unit-test runner is generated from the suites present: each
# tests/unit/test_<unit>.f90 provides module test_<unit> with suite_<unit>().
$(RUNNER): $(TEST_SRC) | $(BUILD)
	@{ echo 'program run_unit_tests'; \
	   echo '  use mpi_f08, only: MPI_Init, MPI_Finalize, MPI_Comm, MPI_Comm_dup, MPI_COMM_WORLD'; \
	   echo '  use testing, only: testing_init, testing_summary'; \
	   for s in $(SUITES); do echo "  use test_$$s, only: suite_$$s"; done; \
	   echo '  implicit none'; \
	   echo '  type(MPI_Comm) :: comm'; \
	   echo '  integer :: nfailed'; \
	   echo '  call MPI_Init()'; \
	   echo '  call MPI_Comm_dup(MPI_COMM_WORLD, comm)'; \
	   echo '  call testing_init(comm)'; \
	   for s in $(SUITES); do echo "  call suite_$$s()"; done; \
	   echo '  nfailed = testing_summary()'; \
	   echo '  call MPI_Finalize()'; \
	   echo '  if (nfailed > 0) error stop 1'; \
	   echo 'end program run_unit_tests'; } > $@

$(BUILD)/run_unit_tests.o: $(RUNNER) $(TEST_OBJ)
	$(FC) $(FFLAGS) -c $< -o $@

$(BUILD)/unit_tests: $(LIB_OBJ) $(TEST_OBJ) $(BUILD)/run_unit_tests.o
	$(FC) $(FFLAGS) -o $@ $^ $(LDLIBS)

unit: $(BUILD)/unit_tests

test: sph $(BUILD)/unit_tests
	@BUILD=$(BUILD) PYTHON=$(PYTHON) NP_TEST="$(NP_TEST)" bash tests/run_tests.sh

# The validation study behind doc/validation.md: runs circle2d at four
# resolutions, ellipsoid3d at two and the square patches, then the errors,
# convergence orders and figures of postproc/ (doc/postproc.md).  Runs go to
# runs/validate/; VALIDATE_ARGS passes options (e.g. --reuse, --quick).
validate: sph
	$(PYTHON) postproc/validate $(VALIDATE_ARGS)

# Fixed-step benchmarks at 1 and 2 ranks (minutes; needs an idle machine):
# seconds per step, right-hand sides and particle updates per second, peak
# memory, imbalance, communication share; table in runs/bench/bench.md.
bench: sph
	$(PYTHON) tests/bench/run_bench.py $(BENCH_ARGS)

debug:
	$(MAKE) BUILD=build/debug \
	  OPTFLAGS="-O0 -g -fcheck=all -ffpe-trap=invalid,zero,overflow -fbacktrace -finit-real=snan"

clean:
	rm -rf build sph
