# marl_mrta: set-up, build, test, demo and benchmarks in one place.
#   make demo   set up, build, run the main job on the default scenario, write results/
#   make test   set up, build, run every test (gtest, pytest, rostest)
#   make test-fast  set up, build, run the unit tier: gtest and the ROS-free Python tests
#   make bench  run the benchmarks, write results/*.json and print a table
#   make stock-nav [NAV_SRC=clone-or-tarball]  build the stock navigation stack for nav:=stock
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
.DEFAULT_GOAL := help

PKG_DIR := $(patsubst %/,%,$(dir $(abspath $(lastword $(MAKEFILE_LIST)))))
VENV    ?= $(PKG_DIR)/.venv
# Build inside the enclosing catkin workspace when the checkout sits in one's src/,
# otherwise in a workspace of our own inside the checkout (git-ignored).
ENCLOSING_WS := $(abspath $(PKG_DIR)/../..)
ifneq ($(wildcard $(PKG_DIR)/../CMakeLists.txt $(ENCLOSING_WS)/.catkin_workspace),)
  WS ?= $(ENCLOSING_WS)
else
  WS ?= $(PKG_DIR)/.ws
endif
JOBS ?= $(shell nproc)
# The stock navigation stack's source (docs/guide/navigation.md): a clone of ros-planning/navigation
# (noetic-devel) or a tarball of one; by default the one `make stock-nav` last built for this
# workspace, else the tarball in ../shared. Built in a workspace of its own (tools/stock_nav.sh)
# that the project's workspace then overlays.
STOCK_NAV_SOURCE_FILE := $(WS)/build/.stock_nav_source
NAV_SRC ?= $(firstword $(shell cat $(STOCK_NAV_SOURCE_FILE) 2>/dev/null) $(wildcard $(PKG_DIR)/../shared/external/navigation_noetic/navigation_noetic.tar.gz))
NAV_SRC_PATH := $(if $(NAV_SRC),$(abspath $(NAV_SRC)))
STOCK_NAV := bash $(PKG_DIR)/tools/stock_nav.sh

# /usr/bin before any other python3 (ROS runs on the system interpreter); the venv adds torch & co.
export PATH := $(VENV)/bin:/usr/bin:/bin:$(PATH)
# Ubuntu 20.04: catkin_make and ROS's environment come from ROS Noetic's own setup file (Debian 12's
# ROS packages install into /usr and need none).
ROS_DISTRO_SETUP ?= /opt/ros/noetic/setup.bash
ROS_BASE_ENV := $(if $(wildcard $(ROS_DISTRO_SETUP)),source $(ROS_DISTRO_SETUP) &&,)
ROS_ENV := source $(WS)/devel/setup.bash
CATKIN_ARGS := -DPYTHON_EXECUTABLE=$(VENV)/bin/python3 -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON

.PHONY: help setup workspace build test test-fast demo bench lint clean stock-nav stock-nav-if-source
help:
	@sed -n '2,6p' $(PKG_DIR)/Makefile | sed 's/^# *//'

setup:
	@MARL_MRTA_VENV=$(VENV) bash $(PKG_DIR)/tools/bootstrap.sh

workspace:
ifneq ($(WS),$(ENCLOSING_WS))
	@bash $(PKG_DIR)/tools/workspace_view.sh $(PKG_DIR) $(WS)
endif

stock-nav: setup
	@$(STOCK_NAV) build "$(NAV_SRC_PATH)"
	@mkdir -p $(WS)/build && echo "$(NAV_SRC_PATH)" >$(STOCK_NAV_SOURCE_FILE)

# make test builds the stock stack first when there is a source (its tests skip without it).
stock-nav-if-source: setup
	@$(if $(wildcard $(NAV_SRC_PATH)),$(STOCK_NAV) build "$(NAV_SRC_PATH)",echo "stock-nav: no source (make stock-nav NAV_SRC=...): the stock navigation tests will skip")

# With a stock navigation workspace built, the project's workspace overlays it; catkin fixes its
# underlays when cmake runs, so a change of underlay (built, removed) re-runs cmake.
build: setup workspace $(if $(filter test,$(MAKECMDGOALS)),stock-nav-if-source)
	@underlay=$$($(STOCK_NAV) setup-file "$(NAV_SRC_PATH)"); stamp=$(WS)/build/.stock_nav_underlay; \
	  $(ROS_BASE_ENV) if [ -n "$$underlay" ]; then source "$$underlay"; fi; \
	  force=; [ "$$(cat $$stamp 2>/dev/null)" = "$$underlay" ] || force=--force-cmake; \
	  cd $(WS) && catkin_make -j$(JOBS) $(CATKIN_ARGS) $$force && echo "$$underlay" >$$stamp

# Both tiers build the gtests (catkin's `tests`), run in tools/run_tests.sh, and end with one count
# (tools/test_summary.py) and catkin_test_results; the exit status is non-zero on any failure.
TEST_SUMMARY = cd $(WS) && $(ROS_ENV) && status=0 && { python3 $(PKG_DIR)/tools/test_summary.py build/test_results/marl_mrta || status=$$?; } && catkin_test_results build/test_results/marl_mrta && exit $$status

test: build
	@rm -rf $(WS)/build/test_results/marl_mrta
	@cd $(WS) && $(ROS_ENV) && catkin_make -j$(JOBS) $(CATKIN_ARGS) tests
	@cd $(WS) && $(ROS_ENV) && bash $(PKG_DIR)/tools/run_tests.sh all $(WS)/build || true
	@$(TEST_SUMMARY)

test-fast: build
	@rm -rf $(WS)/build/test_results/marl_mrta
	@cd $(WS) && $(ROS_ENV) && catkin_make -j$(JOBS) $(CATKIN_ARGS) tests
	@cd $(WS) && $(ROS_ENV) && bash $(PKG_DIR)/tools/run_tests.sh fast $(WS)/build || true
	@$(TEST_SUMMARY)

demo: build
	@$(ROS_ENV) && bash $(PKG_DIR)/tools/demo.sh

bench: build
	@$(ROS_ENV) && bash $(PKG_DIR)/tools/bench.sh

lint: setup workspace
	@$(ROS_ENV) && catkin_lint -W1 --strict --pkg marl_mrta
	@cd $(PKG_DIR) && python3 -m pyflakes src/marl_mrta test $$(grep -l '^#!.*python' scripts/*) && echo "pyflakes: no problems"

clean:
	rm -rf $(PKG_DIR)/.ws
