# SPDX-License-Identifier: MIT
# Runs one command line and passes when it is refused cleanly: a non-zero exit status (not a
# signal, not a timeout) and output (stdout + stderr) matching EXPECT, which names the flag.
#   cmake -DCOMMAND_LINE=prog|--flag|value -DEXPECT=regex -P expect_clean_error.cmake
# ('|' separates the arguments: a ';' would be split by add_test already.)
string(REPLACE "|" ";" command "${COMMAND_LINE}")
execute_process(COMMAND ${command} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
set(all "${out}${err}")
if(NOT rc MATCHES "^[0-9]+$")
  message(FATAL_ERROR "${COMMAND_LINE}: did not exit cleanly (${rc}):\n${all}")
endif()
if(rc EQUAL 0)
  message(FATAL_ERROR "${COMMAND_LINE}: accepted (exit 0):\n${all}")
endif()
if(NOT all MATCHES "${EXPECT}")
  message(FATAL_ERROR "${COMMAND_LINE}: exit ${rc}, but the message does not match '${EXPECT}':\n${all}")
endif()
message(STATUS "${COMMAND_LINE}: exit ${rc}: ${all}")
