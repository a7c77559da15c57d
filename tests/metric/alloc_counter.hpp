// Counts global operator new calls while armed: the "no allocation per frame" checks.
#pragma once

namespace kata::test {
void arm_alloc_counter();       // resets the count and starts counting
long disarm_alloc_counter();    // stops counting; returns allocations seen while armed
}  // namespace kata::test
