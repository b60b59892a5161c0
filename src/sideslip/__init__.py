"""sideslip: vehicle sideslip, roll/bank, heading, bias and trajectory estimation from low-cost sensors.

Conventions (written once, used everywhere in the package)
-----------------------------------------------------------
* Units are SI; angles are radians unless a name ends in ``_deg``.
* Vehicle axes follow ISO 8855: x forward, y left, z up.  Roll ``phi`` is positive when the
  right side goes down, pitch ``theta`` positive nose down, yaw ``psi`` positive to the left.
* The navigation frame is local East-North-Up (ENU).  Yaw is measured from East,
  counter-clockwise positive, so a left turn has ``r = d(psi)/dt > 0``.
* Sideslip ``beta = atan2(v_y, v_x)`` of the body velocity at the centre of gravity (CG);
  course ``nu = psi + beta = atan2(v_n, v_e)``.
* Road bank uses the roll sign: a positive bank lowers the road's right edge.
* The accelerometer measures specific force.  With body roll ``phi`` (relative to the local
  horizontal, suspension roll plus road bank) its lateral channel reads
  ``a_y,m = a_y + g sin(phi)``, where ``a_y`` is the gravity-free lateral acceleration.
* Cornering stiffness ``cf``, ``cr`` is per axle (N/rad) unless a name says ``_per_tyre``.
"""

__version__ = "0.1.0"
