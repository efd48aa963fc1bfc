// Public interface of the CPU reference renderer: everything other modules call.
#pragma once
#include "cpu/integrator.h"
#include "cpu/intersect.h"
#include "cpu/probe.h"
#include "cpu/render.h"
#include "cpu/rng.h"
#include "cpu/surface.h"
