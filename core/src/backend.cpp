// SPDX-License-Identifier: MIT
#include "modrt/backend.h"

namespace modrt {

const char* backend_kind_name(BackendKind kind) {
  switch (kind) {
    case BackendKind::cpu: return "cpu";
    case BackendKind::gles: return "gles";
    case BackendKind::reference: return "reference";
    case BackendKind::count: break;
  }
  return "unknown";
}

}  // namespace modrt
