# marl_mrta: set-up, build, test, demo and benchmarks in one place.
#   make demo   set up, build, run the main job on the default scenario, write results/
#   make test   set up, build, run every test (gtest, pytest, rostest)
#   make bench  run the benchmarks, write results/*.json and print a table
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

# /usr/bin before any other python3 (ROS runs on the system interpreter); the venv adds torch & co.
export PATH := $(VENV)/bin:/usr/bin:/bin:$(PATH)
ROS_ENV := source $(WS)/devel/setup.bash
CATKIN_ARGS := -DPYTHON_EXECUTABLE=$(VENV)/bin/python3 -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON

.PHONY: help setup workspace build test demo bench lint clean
help:
	@sed -n '2,5p' $(PKG_DIR)/Makefile | sed 's/^# *//'

setup:
	@MARL_MRTA_VENV=$(VENV) bash $(PKG_DIR)/tools/bootstrap.sh

workspace:
ifneq ($(WS),$(ENCLOSING_WS))
	@bash $(PKG_DIR)/tools/workspace_view.sh $(PKG_DIR) $(WS)
endif

build: setup workspace
	@cd $(WS) && catkin_make -j$(JOBS) $(CATKIN_ARGS)

test: build
	@rm -rf $(WS)/build/test_results/marl_mrta
	@cd $(WS) && $(ROS_ENV) && catkin_make -j1 $(CATKIN_ARGS) run_tests
	@cd $(WS) && $(ROS_ENV) && status=0 && { python3 $(PKG_DIR)/tools/test_summary.py build/test_results/marl_mrta || status=$$?; } && catkin_test_results build/test_results/marl_mrta && exit $$status

demo: build
	@$(ROS_ENV) && bash $(PKG_DIR)/tools/demo.sh

bench: build
	@$(ROS_ENV) && bash $(PKG_DIR)/tools/bench.sh

lint: setup workspace
	@$(ROS_ENV) && catkin_lint -W1 --strict --pkg marl_mrta
	@cd $(PKG_DIR) && python3 -m pyflakes src/marl_mrta test $$(grep -l '^#!.*python' scripts/*) && echo "pyflakes: no problems"

clean:
	rm -rf $(PKG_DIR)/.ws
