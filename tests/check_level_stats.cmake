# SPDX-License-Identifier: MIT
# ctest cli_level_stats: modrt-level --stats on the corridor preset (two blocks, the light in the
# south one) with the committed tiny dictionary, one bounce. The JSON must list both blocks by
# name and cell, with finite mean indirect and direct light, the lit south block brighter than
# the north one in both (so that a file of zeros or swapped blocks fails).
#
#   cmake -DLEVEL=modrt-level -DDICT=tiny.modrt -DWORK=dir -P check_level_stats.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
execute_process(COMMAND "${LEVEL}" --level corridor --dictionary "${DICT}" --out "${WORK}" --bounces 0
                        --stats "${WORK}/stats.json"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "modrt-level --stats failed (${rc}):\n${out}\n${err}")
endif()
file(READ "${WORK}/stats.json" json)
string(JSON count LENGTH "${json}" blocks)
if(NOT count EQUAL 2)
  message(FATAL_ERROR "expected 2 blocks, got ${count}:\n${json}")
endif()
foreach(i 0 1)
  string(JSON name GET "${json}" blocks ${i} name)
  string(JSON z GET "${json}" blocks ${i} cell 2)
  foreach(what mean_indirect_E_over_pi mean_direct)
    foreach(ch 0 1 2)
      string(JSON v GET "${json}" blocks ${i} ${what} ${ch})
      if(NOT v MATCHES "^[0-9.eE+-]+$")
        message(FATAL_ERROR "block ${i} ${what}[${ch}] is not a finite number: '${v}'")
      endif()
      set(${what}_${name}_${ch} ${v})
    endforeach()
  endforeach()
  set(cell_z_${name} ${z})
endforeach()
if(NOT cell_z_south EQUAL 0 OR NOT cell_z_north EQUAL 1)
  message(FATAL_ERROR "blocks south / north not at cells z 0 / 1:\n${json}")
endif()
foreach(what mean_indirect_E_over_pi mean_direct)
  foreach(ch 0 1 2)
    if(NOT ${what}_south_${ch} GREATER ${what}_north_${ch})
      message(FATAL_ERROR "${what}[${ch}]: the lit south block (${${what}_south_${ch}}) is not brighter than the "
                          "north one (${${what}_north_${ch}})")
    endif()
  endforeach()
endforeach()
message(STATUS "level stats: south ${mean_indirect_E_over_pi_south_0}, north ${mean_indirect_E_over_pi_north_0}")
