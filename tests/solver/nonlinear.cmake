# Nonlinear proof-of-correctness tests of the solver (issue 4): cart-pole, unicycle with
# obstacles and a speed-profile equality, rigid body on SE(3); problems with many active
# bounds (issue 17): two-link arm, planar quadrotor, bicycle; Ipopt reference on the same
# multiple-shooting transcription. Included from tests/solver/CMakeLists.txt:
#   include(${CMAKE_CURRENT_SOURCE_DIR}/nonlinear.cmake OPTIONAL)

set(_nl_dir ${CMAKE_CURRENT_LIST_DIR})

# Reusable problem definitions and helpers (ocp layer only).
if(TARGET rollstep::ocp AND NOT TARGET rollstep_nltest_problems)
  add_library(rollstep_nltest_problems STATIC ${_nl_dir}/nonlinear_problems.cpp)
  target_include_directories(rollstep_nltest_problems PUBLIC ${_nl_dir})
  target_link_libraries(rollstep_nltest_problems PUBLIC rollstep::ocp)
  rollstep_target_defaults(rollstep_nltest_problems)

  rollstep_add_test(nonlinear_problems_test
    SOURCES ${_nl_dir}/nonlinear_problems_test.cpp
    LIBS rollstep_nltest_problems
    LABELS solver)
endif()

# Ipopt reference (tests only).
pkg_check_modules(IPOPT IMPORTED_TARGET ipopt)
if(TARGET rollstep_nltest_problems AND IPOPT_FOUND AND NOT TARGET rollstep_nltest_ipopt)
  add_library(rollstep_nltest_ipopt STATIC ${_nl_dir}/ipopt_reference.cpp)
  target_link_libraries(rollstep_nltest_ipopt PUBLIC rollstep_nltest_problems PkgConfig::IPOPT)
  rollstep_target_defaults(rollstep_nltest_ipopt)

  rollstep_add_test(ipopt_reference_test
    SOURCES ${_nl_dir}/ipopt_reference_test.cpp
    LIBS rollstep_nltest_ipopt
    LABELS solver)

  if(TARGET rollstep::solver)
    rollstep_add_test(nonlinear_comparison_test
      SOURCES ${_nl_dir}/nonlinear_comparison_test.cpp
      LIBS rollstep::solver rollstep_nltest_ipopt
      LABELS solver)
    # Issue 17: problems with many active bounds, two starts, default settings and
    # Gauss-Newton, against Ipopt from the same start (single-threaded solves: the
    # ThreadSanitizer tree leaves them out, scripts/sanitize).
    rollstep_add_test(nonlinear_robustness_test
      SOURCES ${_nl_dir}/nonlinear_robustness_test.cpp
      LIBS rollstep::solver rollstep_nltest_ipopt
      LABELS solver)
    # Random starts against Ipopt (about 35 s: labelled slow, out of the sanitizer trees).
    rollstep_add_test(random_starts_test
      SOURCES ${_nl_dir}/random_starts_test.cpp
      LIBS rollstep::solver rollstep_nltest_ipopt
      LABELS solver slow)
    rollstep_add_test(second_order_correction_test
      SOURCES ${_nl_dir}/second_order_correction_test.cpp
      LIBS rollstep::solver rollstep_nltest_ipopt
      LABELS solver)
    rollstep_add_test(nonlinear_realtime_test
      SOURCES ${_nl_dir}/nonlinear_realtime_test.cpp
      LIBS rollstep::solver rollstep_nltest_problems
      LABELS solver)
    rollstep_add_test(nonlinear_failure_test
      SOURCES ${_nl_dir}/nonlinear_failure_test.cpp
      LIBS rollstep::solver rollstep_nltest_problems
      LABELS solver)
  endif()
elseif(NOT IPOPT_FOUND)
  message(STATUS "rollstep: Ipopt not found, Ipopt reference tests skipped")
endif()
