// The time integrators a deck can choose (time.integrator; docs/method.md#time-integrators).
#pragma once

namespace hyperqn {

enum class TimeIntegrator { implicit_euler, implicit_midpoint };

}  // namespace hyperqn
