/* The process-wide state of the synthesiser's kernels (synth_common.h). */
#include "synth_common.h"

int synth_isa_cap = 2;
