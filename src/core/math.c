/* math.c: 4x4 matrices (column-major, m[c*4+r]) and vector helpers. */
#include "obs.h"

#include <math.h>
#include <string.h>

float obs_v3_length(obs_vec3 a) { return sqrtf(obs_v3_dot(a, a)); }

obs_vec3 obs_v3_normalize(obs_vec3 a)
{
    /* In double, so that tiny and huge vectors normalise without under/overflow. */
    double x = a.x, y = a.y, z = a.z;
    double l = sqrt(x * x + y * y + z * z);
    if (!(l > 0.0) || !isfinite(l))
        return obs_v3(0.0f, 0.0f, 0.0f);
    return obs_v3((float)(x / l), (float)(y / l), (float)(z / l));
}

obs_mat4 obs_mat4_identity(void)
{
    obs_mat4 r;
    memset(&r, 0, sizeof r);
    r.m[0] = r.m[5] = r.m[10] = r.m[15] = 1.0f;
    return r;
}

obs_mat4 obs_mat4_mul(obs_mat4 a, obs_mat4 b)
{
    obs_mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0; /* accumulate in double: node chains stay accurate */
            for (int k = 0; k < 4; k++)
                s += (double)a.m[k * 4 + row] * (double)b.m[c * 4 + k];
            r.m[c * 4 + row] = (float)s;
        }
    return r;
}

obs_dmat4 obs_mat4_to_double(obs_mat4 a)
{
    obs_dmat4 r;
    for (int i = 0; i < 16; i++)
        r.m[i] = a.m[i];
    return r;
}

obs_dmat4 obs_dmat4_mul(obs_dmat4 a, obs_dmat4 b)
{
    obs_dmat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a.m[k * 4 + row] * b.m[c * 4 + k];
            r.m[c * 4 + row] = s;
        }
    return r;
}

int obs_mat4_is_finite(obs_mat4 a)
{
    for (int i = 0; i < 16; i++)
        if (!isfinite(a.m[i]))
            return 0;
    return 1;
}

/* Inverse by cofactor expansion in double. */
int obs_mat4_inverse(obs_mat4 a, obs_mat4 *out)
{
    double m[16], inv[16];
    for (int i = 0; i < 16; i++)
        m[i] = a.m[i];
    inv[0] = m[5] * m[10] * m[15] - m[5] * m[11] * m[14] - m[9] * m[6] * m[15] + m[9] * m[7] * m[14] +
             m[13] * m[6] * m[11] - m[13] * m[7] * m[10];
    inv[4] = -m[4] * m[10] * m[15] + m[4] * m[11] * m[14] + m[8] * m[6] * m[15] - m[8] * m[7] * m[14] -
             m[12] * m[6] * m[11] + m[12] * m[7] * m[10];
    inv[8] = m[4] * m[9] * m[15] - m[4] * m[11] * m[13] - m[8] * m[5] * m[15] + m[8] * m[7] * m[13] +
             m[12] * m[5] * m[11] - m[12] * m[7] * m[9];
    inv[12] = -m[4] * m[9] * m[14] + m[4] * m[10] * m[13] + m[8] * m[5] * m[14] - m[8] * m[6] * m[13] -
              m[12] * m[5] * m[10] + m[12] * m[6] * m[9];
    inv[1] = -m[1] * m[10] * m[15] + m[1] * m[11] * m[14] + m[9] * m[2] * m[15] - m[9] * m[3] * m[14] -
             m[13] * m[2] * m[11] + m[13] * m[3] * m[10];
    inv[5] = m[0] * m[10] * m[15] - m[0] * m[11] * m[14] - m[8] * m[2] * m[15] + m[8] * m[3] * m[14] +
             m[12] * m[2] * m[11] - m[12] * m[3] * m[10];
    inv[9] = -m[0] * m[9] * m[15] + m[0] * m[11] * m[13] + m[8] * m[1] * m[15] - m[8] * m[3] * m[13] -
             m[12] * m[1] * m[11] + m[12] * m[3] * m[9];
    inv[13] = m[0] * m[9] * m[14] - m[0] * m[10] * m[13] - m[8] * m[1] * m[14] + m[8] * m[2] * m[13] +
              m[12] * m[1] * m[10] - m[12] * m[2] * m[9];
    inv[2] = m[1] * m[6] * m[15] - m[1] * m[7] * m[14] - m[5] * m[2] * m[15] + m[5] * m[3] * m[14] +
             m[13] * m[2] * m[7] - m[13] * m[3] * m[6];
    inv[6] = -m[0] * m[6] * m[15] + m[0] * m[7] * m[14] + m[4] * m[2] * m[15] - m[4] * m[3] * m[14] -
             m[12] * m[2] * m[7] + m[12] * m[3] * m[6];
    inv[10] = m[0] * m[5] * m[15] - m[0] * m[7] * m[13] - m[4] * m[1] * m[15] + m[4] * m[3] * m[13] +
              m[12] * m[1] * m[7] - m[12] * m[3] * m[5];
    inv[14] = -m[0] * m[5] * m[14] + m[0] * m[6] * m[13] + m[4] * m[1] * m[14] - m[4] * m[2] * m[13] -
              m[12] * m[1] * m[6] + m[12] * m[2] * m[5];
    inv[3] = -m[1] * m[6] * m[11] + m[1] * m[7] * m[10] + m[5] * m[2] * m[11] - m[5] * m[3] * m[10] -
             m[9] * m[2] * m[7] + m[9] * m[3] * m[6];
    inv[7] = m[0] * m[6] * m[11] - m[0] * m[7] * m[10] - m[4] * m[2] * m[11] + m[4] * m[3] * m[10] +
             m[8] * m[2] * m[7] - m[8] * m[3] * m[6];
    inv[11] = -m[0] * m[5] * m[11] + m[0] * m[7] * m[9] + m[4] * m[1] * m[11] - m[4] * m[3] * m[9] -
              m[8] * m[1] * m[7] + m[8] * m[3] * m[5];
    inv[15] = m[0] * m[5] * m[10] - m[0] * m[6] * m[9] - m[4] * m[1] * m[10] + m[4] * m[2] * m[9] +
              m[8] * m[1] * m[6] - m[8] * m[2] * m[5];
    double det = m[0] * inv[0] + m[1] * inv[4] + m[2] * inv[8] + m[3] * inv[12];
    if (det == 0.0 || !isfinite(det))
        return 0;
    double inv_det = 1.0 / det;
    obs_mat4 r;
    for (int i = 0; i < 16; i++) {
        r.m[i] = (float)(inv[i] * inv_det);
        if (!isfinite(r.m[i]))
            return 0;
    }
    *out = r;
    return 1;
}

obs_mat4 obs_mat4_transpose(obs_mat4 a)
{
    obs_mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++)
            r.m[c * 4 + row] = a.m[row * 4 + c];
    return r;
}

obs_mat4 obs_mat4_translation(obs_vec3 t)
{
    obs_mat4 r = obs_mat4_identity();
    r.m[12] = t.x;
    r.m[13] = t.y;
    r.m[14] = t.z;
    return r;
}

obs_mat4 obs_mat4_scale(obs_vec3 s)
{
    obs_mat4 r = obs_mat4_identity();
    r.m[0] = s.x;
    r.m[5] = s.y;
    r.m[10] = s.z;
    return r;
}

/* Rotation matrix of a unit quaternion (x, y, z, w); normalised first so that slightly
 * denormalised glTF quaternions still give a rotation. */
obs_mat4 obs_mat4_from_quat(obs_vec4 q)
{
    double x = q.x, y = q.y, z = q.z, w = q.w;
    double n = sqrt(x * x + y * y + z * z + w * w);
    if (n > 0.0) {
        x /= n;
        y /= n;
        z /= n;
        w /= n;
    } else {
        w = 1.0;
    }
    obs_mat4 r = obs_mat4_identity();
    r.m[0] = (float)(1 - 2 * (y * y + z * z));
    r.m[1] = (float)(2 * (x * y + z * w));
    r.m[2] = (float)(2 * (x * z - y * w));
    r.m[4] = (float)(2 * (x * y - z * w));
    r.m[5] = (float)(1 - 2 * (x * x + z * z));
    r.m[6] = (float)(2 * (y * z + x * w));
    r.m[8] = (float)(2 * (x * z + y * w));
    r.m[9] = (float)(2 * (y * z - x * w));
    r.m[10] = (float)(1 - 2 * (x * x + y * y));
    return r;
}

obs_mat4 obs_mat4_from_trs(obs_vec3 t, obs_vec4 q, obs_vec3 s)
{
    return obs_mat4_mul(obs_mat4_translation(t), obs_mat4_mul(obs_mat4_from_quat(q), obs_mat4_scale(s)));
}

obs_mat4 obs_mat4_look_at(obs_vec3 eye, obs_vec3 target, obs_vec3 up)
{
    obs_vec3 f = obs_v3_normalize(obs_v3_sub(target, eye)); /* forward = -Z of view */
    obs_vec3 s = obs_v3_normalize(obs_v3_cross(f, up));     /* right = +X */
    if (obs_v3_dot(s, s) == 0.0f) /* up parallel to forward: pick another up */
        s = obs_v3_normalize(obs_v3_cross(f, fabsf(f.x) < 0.9f ? obs_v3(1, 0, 0) : obs_v3(0, 0, 1)));
    obs_vec3 u = obs_v3_cross(s, f);
    obs_mat4 r = obs_mat4_identity();
    r.m[0] = s.x; r.m[4] = s.y; r.m[8] = s.z;
    r.m[1] = u.x; r.m[5] = u.y; r.m[9] = u.z;
    r.m[2] = -f.x; r.m[6] = -f.y; r.m[10] = -f.z;
    r.m[12] = -obs_v3_dot(s, eye);
    r.m[13] = -obs_v3_dot(u, eye);
    r.m[14] = obs_v3_dot(f, eye);
    return r;
}

obs_vec3 obs_mat4_mul_point(obs_mat4 m, obs_vec3 p)
{
    return obs_v3(m.m[0] * p.x + m.m[4] * p.y + m.m[8] * p.z + m.m[12],
                  m.m[1] * p.x + m.m[5] * p.y + m.m[9] * p.z + m.m[13],
                  m.m[2] * p.x + m.m[6] * p.y + m.m[10] * p.z + m.m[14]);
}

obs_vec3 obs_mat4_mul_dir(obs_mat4 m, obs_vec3 d)
{
    return obs_v3(m.m[0] * d.x + m.m[4] * d.y + m.m[8] * d.z, m.m[1] * d.x + m.m[5] * d.y + m.m[9] * d.z,
                  m.m[2] * d.x + m.m[6] * d.y + m.m[10] * d.z);
}

obs_vec4 obs_mat4_mul_vec4(obs_mat4 m, obs_vec4 v)
{
    obs_vec4 r;
    r.x = m.m[0] * v.x + m.m[4] * v.y + m.m[8] * v.z + m.m[12] * v.w;
    r.y = m.m[1] * v.x + m.m[5] * v.y + m.m[9] * v.z + m.m[13] * v.w;
    r.z = m.m[2] * v.x + m.m[6] * v.y + m.m[10] * v.z + m.m[14] * v.w;
    r.w = m.m[3] * v.x + m.m[7] * v.y + m.m[11] * v.z + m.m[15] * v.w;
    return r;
}

int obs_mat4_normal_matrix(obs_mat4 m, obs_mat4 *out)
{
    obs_mat4 a = m;
    a.m[12] = a.m[13] = a.m[14] = 0.0f;
    a.m[3] = a.m[7] = a.m[11] = 0.0f;
    a.m[15] = 1.0f;
    obs_mat4 inv;
    if (!obs_mat4_inverse(a, &inv))
        return 0;
    *out = obs_mat4_transpose(inv);
    out->m[15] = 0.0f;
    return 1;
}
