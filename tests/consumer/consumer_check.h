// SPDX-License-Identifier: MIT
/* The consumer programs' error check: a failing modrt call prints its status and message. */
#ifndef MODRT_CONSUMER_CHECK_H
#define MODRT_CONSUMER_CHECK_H

#include <stdio.h>

#include <modrt/modrt.h>

#define CHECK(call)                                                                             \
  do {                                                                                          \
    modrt_status s_ = (call);                                                                   \
    if (s_ != MODRT_OK) {                                                                       \
      fprintf(stderr, "%s failed: %s: %s\n", #call, modrt_status_name(s_), modrt_last_error()); \
      return 1;                                                                                 \
    }                                                                                           \
  } while (0)

#endif
