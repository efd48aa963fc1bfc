#version 460
// Placeholder: replaced by the path tracer.
#extension GL_GOOGLE_include_directive : require
#include "shared/layout.h"
layout(local_size_x = 64) in;
void main() {}
