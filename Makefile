# sph: build, test, clean.  The sources are src/<layer>/*.f90, one folder per
# layer (doc/developer/architecture.md); objects and module files go to $(BUILD), flat;
# the executable is ./sph.  Dependencies between modules are read from the
# `use` statements (file name = module name, unique over the folders), so the
# order is automatic and a new file or folder needs no edit here.

# FC: the MPI Fortran wrapper (make's built-in default f77 is replaced;
# `make FC=...` or the environment picks another).
ifeq ($(origin FC),default)
  FC := mpifort
endif
PYTHON  ?= /usr/bin/python3
BUILD   ?= build/release
NP_TEST ?= 1 2 3

# Parallel HDF5 from its pkg-config file (Debian: libhdf5-openmpi-dev); set
# HDF5_INC (where hdf5.mod is) and HDF5_LIB (where libhdf5_fortran is) to use
# another installation.
HDF5_PC  ?= hdf5-openmpi
HDF5_INC ?= $(patsubst -I%,%,$(firstword $(shell pkg-config --cflags-only-I $(HDF5_PC) 2>/dev/null)))
HDF5_LIB ?= $(patsubst -L%,%,$(firstword $(shell pkg-config --libs-only-L $(HDF5_PC) 2>/dev/null)))
# without pkg-config: the paths the HDF5 compiler wrapper h5pfc uses
ifeq ($(strip $(HDF5_INC)),)
  HDF5_SHOW := $(shell h5pfc -show 2>/dev/null)
  HDF5_INC := $(patsubst -I%,%,$(firstword $(filter -I%,$(HDF5_SHOW))))
  HDF5_LIB := $(patsubst -L%,%,$(firstword $(filter -L%,$(HDF5_SHOW))))
endif
HDF5_INC := $(HDF5_INC)
HDF5_LIB := $(HDF5_LIB)
ifeq ($(strip $(HDF5_INC)),)
  $(error parallel HDF5 not found by pkg-config $(HDF5_PC) nor h5pfc: install libhdf5-openmpi-dev, or set HDF5_INC and HDF5_LIB)
endif

# -march=native: the code is always compiled on the machine that runs it
# (README, CI); it enables AVX2/FMA on these machines.  No -ffast-math: NaN
# detection and run-to-run reproducibility rely on IEEE semantics.
OPTFLAGS ?= -O3 -march=native
WFLAGS   := -std=f2018 -Wall -Wextra -Wimplicit-interface -fimplicit-none
FFLAGS   := $(OPTFLAGS) $(WFLAGS) -J$(BUILD) -I$(BUILD) -I$(HDF5_INC) -I/usr/include
LDLIBS   := -L$(HDF5_LIB) -Wl,-rpath,$(HDF5_LIB) -lhdf5_fortran -lhdf5 -lfftw3 -lmetis

# EXCLUDE (file names without extension or folder) leaves work in progress
# out of a build, e.g. EXCLUDE=test_eos a unit-test suite.
EXCLUDE   ?=
# (*.F90: sources the C preprocessor expands first, e.g. the particle fields;
# *.fypp: modules fypp generates into $(BUILD)/*.f90 first, e.g. the
# specialised pair loops; *.fypi: fypp text they include)
SRC_DIRS  := $(patsubst %/,%,$(sort $(dir $(wildcard src/*/*.f90 src/*/*.F90 src/*/*.fypp))))
SRC       := $(filter-out $(foreach e,$(EXCLUDE),%/$(e).f90 %/$(e).F90 %/$(e).fypp),\
                          $(wildcard src/*/*.f90 src/*/*.F90 src/*/*.fypp))
LIB_SRC   := $(filter-out %/main.f90,$(SRC))
SUITES    := $(filter-out $(patsubst test_%,%,$(EXCLUDE)),\
               $(patsubst tests/unit/test_%.pf,%,$(wildcard tests/unit/test_*.pf)))
PF_SRC    := $(patsubst %,tests/unit/test_%.pf,$(SUITES))

# sorted by name: the link order of the flat layout
LIB_OBJ   := $(sort $(addprefix $(BUILD)/,$(addsuffix .o,$(basename $(notdir $(LIB_SRC))))))

vpath %.f90 $(SRC_DIRS) tests
vpath %.F90 $(SRC_DIRS)
vpath %.fypp $(SRC_DIRS)

# fypp (Debian: fypp) expands a .fypp module into $(BUILD)/<name>.f90, with
# the source's folder on its include path
FYPP      ?= fypp
FYPP_SRC  := $(filter %.fypp,$(SRC))
FYPP_F90  := $(addprefix $(BUILD)/,$(notdir $(FYPP_SRC:.fypp=.f90)))

.PHONY: validate-squares all sph debug asan test unit bench bench-pairloop decomp-study validate validate-long reference reference-bem input-doc clean
all: sph

# copy then rename: replaces ./sph atomically, even while it is running
sph: $(BUILD)/sph
	cp $< $@.tmp && mv -f $@.tmp $@

$(BUILD)/sph: $(LIB_OBJ) $(BUILD)/main.o
	$(FC) $(FFLAGS) -o $@ $^ $(LDLIBS)

$(BUILD)/%.o: %.f90 | $(BUILD)
	$(FC) $(FFLAGS) -c $< -o $@

$(BUILD)/%.o: %.F90 | $(BUILD)
	$(FC) $(FFLAGS) -c $< -o $@

# A case implements case_t's bindings and may ignore an argument on purpose
# (case_t's defaults, and a case's setup, need not use every argument the
# interface passes); so in src/cases/case_*.f90 only, not in what they use.
$(BUILD)/case_%.o: private FFLAGS += -Wno-unused-dummy-argument

$(FYPP_F90): $(BUILD)/%.f90: %.fypp | $(BUILD)
	$(FYPP) -I $(dir $<) $< $@.tmp && mv -f $@.tmp $@

$(FYPP_F90:.f90=.o): $(BUILD)/%.o: $(BUILD)/%.f90
	$(FC) $(FFLAGS) -c $< -o $@

$(BUILD):
	mkdir -p $@

# Module dependencies: "use foo" in any source makes its object depend on
# $(BUILD)/foo.o when foo is one of ours (for a .pf file: the objects of
# both unit-test builds below); "include 'bar.inc'" (or the preprocessor's
# #include "bar.inc") on bar.inc when it lies beside the source (system
# headers such as fftw3.f03 are not tracked).
DEP_SRC := $(SRC) tests/testing.f90 tests/bitwise.f90 $(PF_SRC)
$(BUILD)/deps.mk: $(DEP_SRC) | $(BUILD)
	@for f in $(DEP_SRC); do \
	  b=$$(basename $$f); b=$${b%.*}; \
	  case $$f in *.pf) o="$(PF2F90)/$$b.o $(PFB)/$$b.o";; *) o=$(BUILD)/$$b.o;; esac; \
	  for m in $$(sed -nE 's/^[[:space:]]*use[[:space:]]*(,[[:space:]]*non_intrinsic[[:space:]]*::)?[[:space:]]*([A-Za-z0-9_]+).*/\2/Ip' $$f | tr A-Z a-z | sort -u); do \
	    for d in $(SRC_DIRS) tests; do \
	      if [ -f $$d/$$m.f90 -o -f $$d/$$m.F90 -o -f $$d/$$m.fypp ] && [ $$m != $$b ]; then echo "$$o: $(BUILD)/$$m.o"; fi; \
	    done; \
	  done; \
	  case $$f in *.fypp) t=$(BUILD)/$$b.f90;; *) t=$$o;; esac; \
	  for i in $$(sed -nE "s/^[[:space:]]*#?:?[[:space:]]*include[[:space:]]*['\"]([^'\"]+)['\"].*/\1/Ip" $$f | sort -u); do \
	    if [ -f $$(dirname $$f)/$$i ]; then echo "$$t: $$(dirname $$f)/$$i"; fi; \
	  done; \
	done > $@
-include $(BUILD)/deps.mk

# ---------------------------------------------------------------- unit tests
# tests/unit/test_<unit>.pf are written in pFUnit's test language.  With
# pFUnit 4 installed (PFUNIT_DIR, on the command line or in the environment:
# its PFUNIT-4.x directory, the prefix holding it or its cmake/ directory),
# pFUnit's preprocessor and driver build them; without it, tests/pf2f90.py
# translates them for the harness tests/testing.f90.  Either way
# tests/run_tests.sh runs the result (doc/developer/testing.md, "Unit tests").
PF2F90 := $(BUILD)/pf2f90
PFB    := $(BUILD)/pfunit

ifneq ($(strip $(PFUNIT_DIR)),)
PFUNIT_MK := $(firstword $(wildcard $(PFUNIT_DIR)/include/PFUNIT.mk \
                                    $(PFUNIT_DIR)/PFUNIT-*/include/PFUNIT.mk \
                                    $(PFUNIT_DIR)/../include/PFUNIT.mk))
ifeq ($(PFUNIT_MK),)
$(error PFUNIT_DIR=$(PFUNIT_DIR) has no include/PFUNIT.mk: give pFUnit's PFUNIT-4.x directory)
endif
# before PFUNIT.mk: without it PFUNIT_LIBRARIES lacks -lpfunit (MpiTestMethod)
USEMPI := YES
include $(PFUNIT_MK)

# The steps of PFUNIT.mk's make_pfunit_test, written out so that funitproc
# runs under $(PYTHON) (its "#!/usr/bin/env python" finds no python on
# Debian) and everything it makes stays in $(PFB).
PF_FFLAGS := $(OPTFLAGS) -fimplicit-none -J$(PFB) -I$(BUILD) -I$(HDF5_INC) $(PFUNIT_EXTRA_FFLAGS)
PF_OBJ    := $(patsubst %,$(PFB)/test_%.o,$(SUITES))
UNIT_EXE  := $(PFB)/unit_tests
UNIT_KIND := pfunit
UNIT_LABEL = pFUnit $(PFUNIT_VERSION) from $(PFUNIT_TOP_DIR)

$(PFB)/test_%.F90: tests/unit/test_%.pf | $(PFB)
	$(PYTHON) $(PFUNIT_BIN_DIR)/funitproc -quiet $< $@

$(PF_OBJ): $(PFB)/%.o: $(PFB)/%.F90 $(BUILD)/bitwise.o
	$(FC) $(PF_FFLAGS) -c $< -o $@

$(PFB)/unit_tests.inc: $(PF_SRC) Makefile | $(PFB)
	@printf 'ADD_TEST_SUITE(test_%s_suite)\n' $(SUITES) > $@

$(PFB)/driver.o: $(PFUNIT_INCLUDE_DIR)/driver.F90 $(PFB)/unit_tests.inc
	$(FC) $(PF_FFLAGS) -I$(PFB) -D_TEST_SUITES='"unit_tests.inc"' -c $< -o $@

$(UNIT_EXE): $(PFB)/driver.o $(PF_OBJ) $(LIB_OBJ) $(BUILD)/bitwise.o
	$(FC) $(OPTFLAGS) -o $@ $^ $(LDLIBS) $(PFUNIT_LIBRARIES)

$(PFB):
	mkdir -p $@
else
# The translated suites go to $(PF2F90) with their module files; the
# runner calls each module's test_<unit>_suite() (written by pf2f90.py).
# An @mpitest takes `this` whether it uses it or not: no warning for that.
TFLAGS    := $(OPTFLAGS) $(WFLAGS) -Wno-unused-dummy-argument -J$(PF2F90) -I$(BUILD) \
             -I$(HDF5_INC) -I/usr/include
PF_OBJ    := $(patsubst %,$(PF2F90)/test_%.o,$(SUITES))
UNIT_EXE  := $(BUILD)/unit_tests
UNIT_KIND := pf2f90
UNIT_LABEL = tests/pf2f90.py (pFUnit not found)

$(PF2F90)/test_%.F90: tests/unit/test_%.pf tests/pf2f90.py | $(PF2F90)
	$(PYTHON) tests/pf2f90.py $< $@

$(PF_OBJ): $(PF2F90)/%.o: $(PF2F90)/%.F90 $(BUILD)/testing.o $(BUILD)/bitwise.o
	$(FC) $(TFLAGS) -c $< -o $@

$(PF2F90)/run_unit_tests.f90: $(PF_SRC) Makefile | $(PF2F90)
	@{ echo 'program run_unit_tests'; \
	   echo '  use mpi_f08, only: MPI_Init, MPI_Finalize, MPI_Comm, MPI_Comm_dup, MPI_COMM_WORLD'; \
	   echo '  use testing, only: testing_init, testing_summary'; \
	   for s in $(SUITES); do echo "  use test_$$s, only: test_$${s}_suite"; done; \
	   echo '  implicit none'; \
	   echo '  type(MPI_Comm) :: comm'; \
	   echo '  integer :: nfailed'; \
	   echo '  call MPI_Init()'; \
	   echo '  call MPI_Comm_dup(MPI_COMM_WORLD, comm)'; \
	   echo '  call testing_init(comm)'; \
	   for s in $(SUITES); do echo "  call test_$${s}_suite()"; done; \
	   echo '  nfailed = testing_summary()'; \
	   echo '  call MPI_Finalize()'; \
	   echo '  if (nfailed > 0) error stop 1'; \
	   echo 'end program run_unit_tests'; } > $@

$(PF2F90)/run_unit_tests.o: $(PF2F90)/run_unit_tests.f90 $(PF_OBJ)
	$(FC) $(TFLAGS) -c $< -o $@

$(UNIT_EXE): $(LIB_OBJ) $(BUILD)/testing.o $(BUILD)/bitwise.o $(PF_OBJ) $(PF2F90)/run_unit_tests.o
	$(FC) $(FFLAGS) -o $@ $^ $(LDLIBS)

$(PF2F90):
	mkdir -p $@
endif

unit: $(UNIT_EXE)

test: sph $(UNIT_EXE)
	@BUILD=$(BUILD) PYTHON=$(PYTHON) NP_TEST="$(NP_TEST)" UNIT_EXE=$(UNIT_EXE) \
	  UNIT_KIND=$(UNIT_KIND) UNIT_LABEL="$(UNIT_LABEL)" bash tests/run_tests.sh

# The validation study behind doc/validation/patches.md: runs circle2d at four
# resolutions (the input's defaults, the standard operators and the
# convergent recipe), ellipsoid3d at two and the square patches, then the errors,
# convergence orders and figures of postproc/ (doc/reference/postproc.md).  Runs go to
# runs/validate/; VALIDATE_ARGS passes options (e.g. --reuse, --quick).
validate: sph
	$(PYTHON) postproc/validate $(VALIDATE_ARGS)

# The same with the convergent recipe's fifth level (321,792 particles,
# about 8 hours on two cores); earlier runs are reused, stopped ones
# continued from their checkpoints: it can go in pieces, e.g.
# VALIDATE_ARGS="--wall-limit 10000" (or Ctrl-C), repeated until it reports.
validate-long: sph
	$(PYTHON) postproc/validate --reuse --fifth $(VALIDATE_ARGS)

# The square patches alone against the Gerris reference (issue 35): each at
# 10k, 40k and 90k particles with three schemes, compared with the finest
# level of `make reference`; doc/validation/squares.md.  About two hours on
# two cores; --reuse keeps finished runs.
validate-squares: sph
	$(PYTHON) postproc/validate --reuse --cases square_rotation square_vortical \
	  --report squares.md --np 1 $(VALIDATE_ARGS)

# The square patches' reference by Gerris (postproc/reference, doc/validation/reference.md):
# both cases at REFERENCE_LEVELS (Gerris's finest levels in a box of 8 L:
# 16 to 128 cells per L, about an hour on two cores, most of it the finest),
# levels already analysed reused; then each case's resolution study,
# runs/reference/CASE/study.md.  Not part of `make test`.
REFERENCE_LEVELS ?= 7 8 9 10
reference:
	@for c in square_rotation square_vortical; do \
	  for l in $(REFERENCE_LEVELS); do \
	    [ -f runs/reference/$$c/level_$$l/summary.json ] || \
	      $(PYTHON) postproc/reference run $$c --level $$l || exit 1; \
	  done; \
	  $(PYTHON) postproc/reference study $(foreach l,$(REFERENCE_LEVELS),runs/reference/$$c/level_$(l)) \
	    --json runs/reference/$$c/study.json | tee runs/reference/$$c/study.md; \
	done

# The rotating square by boundary integrals (postproc/reference bem,
# doc/validation/reference.md): BEM_RUNS (nodes:dt:corner exponent:filter order) into
# runs/reference/square_rotation/, runs already there reused; then the
# study, and the finest run cut at its interval of convergence written to
# postproc/sphpost/data/square_rotation_bem (the reference shipped).
# Not part of `make test`.
BEM_DIR := runs/reference/square_rotation
BEM_RUNS ?= 1024:0.005:24:12 1536:0.005:24:12 2048:0.005:24:12 1024:0.0025:24:12 \
            1024:0.005:32:12 1024:0.005:24:8
reference-bem:
	@for r in $(BEM_RUNS); do \
	  set -- $$(echo $$r | tr ':' ' '); \
	  d=$(BEM_DIR)/bem_$$(echo $$r | tr : _); \
	  [ -f $$d/summary.json ] || $(PYTHON) postproc/reference bem --nodes $$1 --dt $$2 \
	    --n-corner $$3 --filter-order $$4 --dir $$d || exit 1; \
	done
	$(PYTHON) postproc/reference bem-study $(foreach r,$(BEM_RUNS),$(BEM_DIR)/bem_$(subst :,_,$(r))) \
	  --json $(BEM_DIR)/bem_study.json --ship postproc/sphpost/data/square_rotation_bem \
	  > $(BEM_DIR)/bem_study.md && cat $(BEM_DIR)/bem_study.md

# Fixed-step benchmarks at 1 and 2 ranks (minutes; needs an idle machine):
# seconds per step, right-hand sides and particle updates per second, peak
# memory, imbalance, communication share; table in runs/bench/bench.md.
# BASELINE=<git revision> builds that revision under build/baseline/ and
# runs both alternately, printing the speed-up per case.
bench: sph
	$(PYTHON) tests/bench/run_bench.py $(BENCH_ARGS) $(if $(BASELINE),--baseline $(BASELINE))

# The standard operators' pair loop alone, on one core: the solver's half
# list, the pair terms on contiguous data (the least any loop pays) and 4 x 8
# cluster pairs, each in double and single precision (seconds; needs an idle
# core); doc/studies/speed.md, "What three times faster would take".
# PAIRLOOP_ARGS: the lattice's side (74: 212,472 particles).
PAIRLOOP_SRC := $(addprefix tests/bench/pairloop/,pairloop_layout.f90 pairloop_double.f90 \
                  pairloop_single.f90 pairloop_bench.f90)
bench-pairloop: build/bench/pairloop_bench
	build/bench/pairloop_bench $(PAIRLOOP_ARGS)

build/bench/pairloop_bench: $(PAIRLOOP_SRC) tests/bench/pairloop/pairloop_kernels.inc
	@mkdir -p build/bench
	$(FC) $(OPTFLAGS) $(WFLAGS) -Jbuild/bench -Ibuild/bench -Itests/bench/pairloop $(PAIRLOOP_SRC) -o $@

# Halo copies, partner ranks, bytes and messages per step and imbalance of
# the slab, METIS and curve decompositions at 2..64 ranks (oversubscribed:
# counts, not times; about half an hour); table in runs/decomp/decomp.md.
decomp-study: sph
	$(PYTHON) tests/bench/decomp_study.py $(DECOMP_ARGS)

# doc/reference/input.md's tables of variables, rewritten from `sph --input-tables`
# (the rows that describe each variable); the test suite checks they agree.
input-doc: sph
	$(PYTHON) tests/integration/test_input_doc.py --write

debug:
	$(MAKE) BUILD=build/debug \
	  OPTFLAGS="-O0 -g -fcheck=all -ffpe-trap=invalid,zero,overflow -fbacktrace -finit-real=snan"

# AddressSanitizer build beside the release one (./sph is left as it is),
# with its unit tests; from the repository's root:
#   ASAN_OPTIONS=detect_leaks=0 mpirun -np 2 build/asan/sph input/circle2d.nml
#   ASAN_OPTIONS=detect_leaks=0 mpirun -np 3 build/asan/unit_tests
# (leak detection off: Open MPI keeps its allocations to the end)
asan:
	$(MAKE) BUILD=build/asan OPTFLAGS="-O1 -g -fsanitize=address -fno-omit-frame-pointer" \
	  build/asan/sph build/asan/unit_tests

clean:
	rm -rf build sph
