/* The direction cosine matrix of a scalar-first unit quaternion, shared by the C extensions.
 *
 * M_BO (NED -> body, sportfusion.core.rotations.dcm_from_quat without its normalisation) of q = (q0, q1, q2, q3);
 * its transpose is the Hamilton rotation matrix R(q) of sportfusion.climbing._so3.
 */
#ifndef SPORTFUSION_QUAT_H
#define SPORTFUSION_QUAT_H

static inline void quat_mbo(double q0, double q1, double q2, double q3, double M[3][3]) {
    M[0][0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3;
    M[0][1] = 2 * (q1 * q2 + q0 * q3);
    M[0][2] = 2 * (q1 * q3 - q0 * q2);
    M[1][0] = 2 * (q1 * q2 - q0 * q3);
    M[1][1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3;
    M[1][2] = 2 * (q2 * q3 + q0 * q1);
    M[2][0] = 2 * (q0 * q2 + q1 * q3);
    M[2][1] = 2 * (q2 * q3 - q0 * q1);
    M[2][2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3;
}

#endif
