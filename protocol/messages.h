// The messages of the geoprox protocol: every method's parameters (protocol/params.h) and
// results (protocol/results.h), with their JSON mapping. docs/protocol.md shows every message.
#pragma once

#include "protocol/params.h"
#include "protocol/results.h"
