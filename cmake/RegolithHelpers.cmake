# Shared build conventions. Every library target is created through these helpers so that all of
# regolith gets the same warnings, include layout, install rules and export set.

set(REGOLITH_WARNINGS -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion
    -Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual -Wnull-dereference
    -Wformat=2 -Wimplicit-fallthrough
    # GCC 12 reports false -Wrestrict / -Wmaybe-uninitialized positives inside libstdc++'s
    # std::string at -O3 (GCC PR 105329, PR 105562); they are not about our code.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict> $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized>)

function(regolith_target_defaults target)
  target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:${REGOLITH_WARNINGS}>)
  if(REGOLITH_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>)
  endif()
endfunction()

# regolith_glue_code(<target>): test, CLI and other glue code is compiled at -O1 in the optimised
# builds (after CMake's -O3 / -O2, so it wins). Glue code calls the libraries that do the work and
# gains nothing from -O2's or -O3's inlining and unrolling, which cost a quarter to a half of its
# compile time (measured with GCC 12: test_terrain_pipeline.cpp 32.8 s at -O2 -> 24.4 s at -O1,
# cmd_map.cpp 26.0 -> 22.0 s; -O3 -> -O2 had already taken cmd_map.cpp from 33 s to 23 s). The
# libraries that do the work (algorithms, runtime, HAL) keep -O3 and every warning; GCC's
# -Wnull-dereference, which depends on the optimiser's value tracking, reports paths -O1 leaves
# unpruned (vector::operator[] behind a checked lease), so glue code goes without it.
function(regolith_glue_code target)
  target_compile_options(${target} PRIVATE
    "$<$<AND:$<OR:$<CONFIG:Release>,$<CONFIG:RelWithDebInfo>>,$<COMPILE_LANGUAGE:CXX>>:-O1;-Wno-null-dereference>")
endfunction()

# regolith_pixel_kernels(<target> [SOURCES ...]): a library (or those of its sources) of pixel and
# model arithmetic, no parsing of outside data. Fuzz builds keep edge coverage, ASan and UBSan in
# it but drop libFuzzer's comparison tracing: its compares are loop bounds and pixel values, which
# teach the fuzzer nothing about the input's structure, and tracing them took 77 % of tests/fuzz
# image's time (296 executions / s), 27-40 % of sfs's and terrain's and 41 % of soil_fit's.
function(regolith_pixel_kernels target)
  cmake_parse_arguments(ARG "" "" "SOURCES" ${ARGN})
  if(NOT REGOLITH_FUZZ)
    return()
  endif()
  if(ARG_SOURCES)
    set_property(SOURCE ${ARG_SOURCES} TARGET_DIRECTORY ${target} APPEND PROPERTY COMPILE_OPTIONS
                 -fno-sanitize-coverage=trace-cmp)
  else()
    target_compile_options(${target} PRIVATE -fno-sanitize-coverage=trace-cmp)
  endif()
endfunction()

# regolith_add_library(<name> SOURCES ... [PUBLIC_LIBS ...] [PRIVATE_LIBS ...])
# Creates target regolith_<name> (alias regolith::<name>), public headers in ./include,
# installed and exported in the regolith CMake package.
function(regolith_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  set(target regolith_${name})
  add_library(${target} STATIC ${ARG_SOURCES})
  add_library(regolith::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME regolith_${name})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LIBS} PRIVATE ${ARG_PRIVATE_LIBS})
  regolith_target_defaults(${target})
  install(TARGETS ${target} EXPORT regolithTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/include)
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endfunction()

# regolith_add_gtest(<name> SOURCES ... LIBS ... [LABELS ...] [COST seconds])
# One GoogleTest executable; every TEST() becomes its own CTest test, labelled `unit` unless
# LABELS says otherwise. Test data paths: REGOLITH_SOURCE_DIR / REGOLITH_SHARED_DIR macros.
# COST: the expected run time of its tests; ctest -j starts costly tests first even without a
# timing history (a fresh clone, CI), so a long test does not run alone at the end.
function(regolith_add_gtest name)
  cmake_parse_arguments(ARG "" "COST" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/common)  # alloc_counter.hpp
  target_compile_definitions(${name} PRIVATE
    REGOLITH_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    REGOLITH_SHARED_DIR="${PROJECT_SOURCE_DIR}/../shared"
    REGOLITH_BINARY_DIR="${PROJECT_BINARY_DIR}")
  regolith_target_defaults(${name})
  regolith_glue_code(${name})
  # gtest_discover_tests() passes properties as a flat list, so a test gets one ctest label: the
  # first (unit / integration / hw). `concurrency` selects suites for the tsan preset instead: it
  # adds the target to `concurrency_tests` (tests/CMakeLists.txt).
  # `serial` runs its tests alone (RUN_SERIAL: real-time tests that measure slips).
  list(GET ARG_LABELS 0 _label)
  set(_props LABELS ${_label})
  if("serial" IN_LIST ARG_LABELS)
    list(APPEND _props RUN_SERIAL TRUE)
  endif()
  if(ARG_COST)
    list(APPEND _props COST ${ARG_COST})
  endif()
  gtest_discover_tests(${name} PROPERTIES ${_props} DISCOVERY_TIMEOUT 60)
  if("concurrency" IN_LIST ARG_LABELS)
    set_property(GLOBAL APPEND PROPERTY REGOLITH_CONCURRENCY_TESTS ${name})
  endif()
endfunction()

# regolith_add_bench(<name> SOURCES ... LIBS ...): a Google Benchmark program in bench/.
function(regolith_add_bench name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} benchmark::benchmark)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/common)  # alloc_counter.hpp
  target_compile_definitions(${name} PRIVATE REGOLITH_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  regolith_target_defaults(${name})
endfunction()

# regolith_add_subdirectories(): every sub-folder of the current folder that has a CMakeLists.txt,
# in name order, except those listed in REGOLITH_SKIP (paths relative to the project root).
function(regolith_add_subdirectories)
  file(GLOB _dirs LIST_DIRECTORIES true ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT _dirs)
  foreach(_dir IN LISTS _dirs)
    file(RELATIVE_PATH _rel ${PROJECT_SOURCE_DIR} ${_dir})
    if(IS_DIRECTORY ${_dir} AND EXISTS ${_dir}/CMakeLists.txt AND NOT _rel IN_LIST REGOLITH_SKIP)
      add_subdirectory(${_dir})
    endif()
  endforeach()
endfunction()

# regolith_register_part(<target> HEADER <include> CALL <statement>)
# A part that registers itself with the `regolith` tool (HAL backends, mock backends, component
# wrappers). tools/ generates the registration code from this list and links the targets that
# exist, so adding a backend or a component is adding a folder. In CALL, `backends` is the
# hal::BackendRegistry to register with.
function(regolith_register_part target)
  cmake_parse_arguments(ARG "" "HEADER;CALL" "" ${ARGN})
  set_property(GLOBAL APPEND PROPERTY REGOLITH_PARTS "${target}|${ARG_HEADER}|${ARG_CALL}")
endfunction()
