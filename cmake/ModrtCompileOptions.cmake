# SPDX-License-Identifier: MIT
# modrt_target_options(<target>): the project's warnings and sanitizer flags, per target.
function(modrt_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion)
  if(MODRT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(MODRT_ASAN)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined
                                             -fno-sanitize-recover=undefined
                                             -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()
