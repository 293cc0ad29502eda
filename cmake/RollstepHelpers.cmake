# Shared build settings for every rollstep target.

# Does -march=native enable AVX-512 under GCC 12.0-12.2? (See rollstep_target_defaults.)
set(ROLLSTEP_GCC12_AVX512 OFF)
if(ROLLSTEP_NATIVE AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU"
   AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12
   AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 12.3)
  include(CheckCXXSourceCompiles)
  set(CMAKE_REQUIRED_FLAGS -march=native)
  if(NOT ROLLSTEP_AVX512)
    set(CMAKE_REQUIRED_FLAGS "-march=native -mno-avx512f")
  endif()
  check_cxx_source_compiles("#ifndef __AVX512F__\n#error no AVX-512\n#endif\nint main() { return 0; }"
    ROLLSTEP_NATIVE_HAS_AVX512_${ROLLSTEP_AVX512})  # one cached result per setting
  unset(CMAKE_REQUIRED_FLAGS)
  if(ROLLSTEP_NATIVE_HAS_AVX512_${ROLLSTEP_AVX512})
    set(ROLLSTEP_GCC12_AVX512 ON)
  endif()
endif()

function(rollstep_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
    -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual
    -Wnull-dereference -Wdouble-promotion -Wformat=2)
  if(ROLLSTEP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(ROLLSTEP_NATIVE)
    # PUBLIC: fixed-size Eigen members change layout with the instruction set, so every
    # consumer of our headers must be compiled with the same flag.
    target_compile_options(${target} PUBLIC -march=native)
    if(NOT ROLLSTEP_AVX512)
      target_compile_options(${target} PUBLIC -mno-avx512f)
    endif()
    if(ROLLSTEP_GCC12_AVX512)
      # GCC 12.0-12.2 (Debian 12's compiler) with AVX-512 enabled by -march=native:
      # - its own intrinsics' deliberately undefined operands (`__m512d __Y = __Y;`) are
      #   reported as maybe-uninitialized wherever Eigen inlines them (GCC bug 105593,
      #   fixed in 12.3), so that warning is off in these builds;
      # - Eigen's 8-wide packet loop, which its runtime bounds never run on a 6- or
      #   7-vector copied into a dynamic block, is reported as array-bounds: kept visible,
      #   not fatal.
      target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized
        -Wno-error=uninitialized -Wno-error=array-bounds)
    endif()
  endif()
  if(ROLLSTEP_SANITIZE)
    string(REPLACE ";" "," _san "${ROLLSTEP_SANITIZE}")
    target_compile_options(${target} PRIVATE -fsanitize=${_san} -fno-omit-frame-pointer
      -fno-sanitize-recover=all)
    target_link_options(${target} PUBLIC -fsanitize=${_san})
    # GCC 12 reports false array-bounds hits in Eigen's AVX code once sanitizer
    # instrumentation changes inlining; keep them visible, not fatal, in these trees.
    target_compile_options(${target} PRIVATE -Wno-error=array-bounds)
  endif()
endfunction()

# rollstep_add_layer(<layer> SOURCES ... [DEPS ...])
# Creates the static library rollstep_<layer>, alias rollstep::<layer>, exported.
function(rollstep_add_layer layer)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target rollstep_${layer})
  add_library(${target} STATIC ${ARG_SOURCES})
  add_library(rollstep::${layer} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${layer} OUTPUT_NAME rollstep_${layer})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:include>)
  target_compile_features(${target} PUBLIC cxx_std_17)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS})
  rollstep_target_defaults(${target})
  install(TARGETS ${target} EXPORT rollstepTargets
    ARCHIVE DESTINATION lib LIBRARY DESTINATION lib RUNTIME DESTINATION bin)
endfunction()

# rollstep_add_test(<name> SOURCES ... [LIBS ...] [LABELS ...] [SERIAL])
# A GoogleTest executable registered with ctest; every test gets its layer label. SERIAL:
# its tests run alone (ctest RUN_SERIAL), for tests that need the machine's cores to
# themselves (a real MPC thread paced by the wall clock).
function(rollstep_add_test name)
  cmake_parse_arguments(ARG "SERIAL" "" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  # A tree that runs none of its tests does not build it by default (the sanitizer trees
  # leave out the closed-loop and slow labels: scripts/sanitize).
  foreach(label IN LISTS ARG_LABELS)
    if(label IN_LIST ROLLSTEP_UNBUILT_TEST_LABELS)
      set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL TRUE)
    endif()
  endforeach()
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} rollstep_test_common GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    ROLLSTEP_ROBOTS_DIR="${ROLLSTEP_ROBOTS_DIR}"
    ROLLSTEP_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data")
  rollstep_target_defaults(${name})
  # A test's own code in Release at ROLLSTEP_TEST_OPTIMIZATION: the time goes into the
  # libraries it calls, which keep -O3; -O3 on the tests' Eigen-heavy set-up and checks
  # cost build time only (25-45 % more CPU time per file). GCC 12 at -O1 reports potential
  # null dereferences inside Eigen's inlined moves that -O3 does not
  # (tests/planning/terrain_test.cpp): visible, not fatal, in test code.
  if(ROLLSTEP_TEST_OPTIMIZATION)
    target_compile_options(${name} PRIVATE
      "$<$<CONFIG:Release>:${ROLLSTEP_TEST_OPTIMIZATION};-Wno-error=null-dereference>")
  endif()
  include(GoogleTest)
  # gtest_discover_tests cannot set a list-valued property (CMake 3.25 splits it: the
  # second label became a property name and was lost), so it gets the first label and a
  # ctest include file read after its own sets all of them on the discovered tests.
  set(first_label "")
  if(ARG_LABELS)
    list(GET ARG_LABELS 0 first_label)
  endif()
  if(ARG_SERIAL)
    gtest_discover_tests(${name} PROPERTIES LABELS "${first_label}" RUN_SERIAL TRUE
      DISCOVERY_TIMEOUT 60)
  else()
    gtest_discover_tests(${name} PROPERTIES LABELS "${first_label}" DISCOVERY_TIMEOUT 60)
  endif()
  list(LENGTH ARG_LABELS label_count)
  if(label_count GREATER 1)
    set(labels_file "${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake")
    file(WRITE "${labels_file}"
      "if(DEFINED ${name}_TESTS)\n"
      "  set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"${ARG_LABELS}\")\n"
      "endif()\n")
    set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${labels_file}")
  endif()
endfunction()
