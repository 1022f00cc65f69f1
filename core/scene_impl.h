/*
 * scene_impl.h - the derived geometry of a scene and the shading helpers
 * shared by scene_parse.c, scene_eval.c and scene_reference.c (private).
 *
 * A qmc_scene is what the user wrote; a qmc__scene_geom is what every
 * evaluation needs (unit vectors, frames, the light's cone, areas),
 * computed once per batch so that no evaluation allocates or repeats it.
 */
#ifndef QMC_SCENE_IMPL_H
#define QMC_SCENE_IMPL_H

#include <math.h>

#include "msg.h"
#include "qmc/result.h"
#include "qmc/scene.h"

#define QMC__SCENE_PI 3.14159265358979323846264338327950288

/* Which part of a scene a validation error is about, so that the parser
 * can point at the line and column that wrote it. */
typedef enum qmc__scene_field {
    QMC__SF_NONE = 0,
    QMC__SF_POINT,
    QMC__SF_NORMAL,
    QMC__SF_VIEW,
    QMC__SF_BRDF,      /* the brdf statement as a whole */
    QMC__SF_ALBEDO,
    QMC__SF_KD,
    QMC__SF_KS,
    QMC__SF_EXPONENT,
    QMC__SF_LIGHT,     /* the light statement as a whole */
    QMC__SF_CENTER,
    QMC__SF_RADIUS,
    QMC__SF_CORNER,
    QMC__SF_EDGE1,
    QMC__SF_EDGE2,
    QMC__SF_RADIANCE,
    QMC__SF_SIGMA_T,
    QMC__SF_COUNT
} qmc__scene_field;

typedef struct qmc__scene_geom {
    qmc_vec3 p;              /* shading point */
    qmc_vec3 n, n1, n2;      /* unit normal and a frame about it */
    qmc_vec3 r, r1, r2;      /* Phong mirror direction and a frame */
    int phong;
    double diffuse;          /* albedo / pi or kd / pi */
    double spec;             /* ks (n + 2) / (2 pi); 0 for Lambert */
    double expo;
    double p_diffuse;        /* mixture probability of the cosine lobe */
    int sphere;
    double radiance, sigma_t;
    /* sphere: unit axis to the center and a frame, distance, radius and
     * the cone's cosine */
    qmc_vec3 a, a1, a2;
    double dist, radius, cos_max;
    double omc;              /* 1 - cos_max, without its cancellation */
    /* rect: corner, edges, m = edge1 x edge2, its unit, area */
    qmc_vec3 c, e1, e2, m, nl;
    double area, inv_m2;
    double height;           /* of the point above the rect's plane */
    double peak_dist;        /* from the point to where r meets the plane */
} qmc__scene_geom;

static inline qmc_vec3 qmc__v3(double x, double y, double z)
{
    qmc_vec3 v = {x, y, z};
    return v;
}
static inline double qmc__dot(qmc_vec3 a, qmc_vec3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline qmc_vec3 qmc__sub(qmc_vec3 a, qmc_vec3 b)
{
    return qmc__v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline qmc_vec3 qmc__add(qmc_vec3 a, qmc_vec3 b)
{
    return qmc__v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline qmc_vec3 qmc__scale(qmc_vec3 a, double s)
{
    return qmc__v3(a.x * s, a.y * s, a.z * s);
}
static inline qmc_vec3 qmc__cross(qmc_vec3 a, qmc_vec3 b)
{
    return qmc__v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z,
                   a.x * b.y - a.y * b.x);
}
static inline double qmc__len(qmc_vec3 a)
{
    return sqrt(qmc__dot(a, a));
}
/* a in the frame (t1, t2, z): t1 * a.x + t2 * a.y + z * a.z. */
static inline qmc_vec3 qmc__to_world(qmc_vec3 a, qmc_vec3 t1, qmc_vec3 t2,
                                     qmc_vec3 z)
{
    return qmc__add(qmc__add(qmc__scale(t1, a.x), qmc__scale(t2, a.y)),
                    qmc__scale(z, a.z));
}

/* A right-handed orthonormal frame (t1, t2) about the unit vector z
 * (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1),
 * 2017). */
void qmc__scene_frame(qmc_vec3 z, qmc_vec3 *t1, qmc_vec3 *t2);

/* Validates s.  Returns 0 or QMC_EDOMAIN with the reason in m (when not
 * NULL) and the field to blame in *field. */
int qmc__scene_validate(const qmc_scene *s, qmc__scene_field *field,
                        qmc__msg *m);

/* The one-field checks, shared with the parser so that it reports the
 * first bad value in file order; v holds the field's 1 or 3 numbers.
 * Returns NULL or a static reason. */
const char *qmc__scene_field_problem(qmc__scene_field f, const double *v);

/* Fills g from a validated scene. */
void qmc__scene_geom_init(const qmc_scene *s, qmc__scene_geom *g);

/* f(w) L_e T(dist) max(0, w . n) for a unit direction w known to reach the
 * light at distance dist. */
double qmc__scene_shade(const qmc__scene_geom *g, qmc_vec3 w, double dist);

/* Whether the ray along unit w hits the light's emitting side; if so sets
 * *dist and *pdf_light (the light technique's solid-angle density of w). */
int qmc__scene_hit(const qmc__scene_geom *g, qmc_vec3 w, double *dist,
                   double *pdf_light);

/* The sphere's hit distance along a direction at cosine u to the axis
 * inside the cone. */
double qmc__scene_sphere_dist(const qmc__scene_geom *g, double u);

/* The techniques' densities and the light technique's sample (scene_eval.c),
 * shared with the audit (scene_audit.c): solid-angle densities of unit w;
 * the light's sample from u[0..2) with its distance and density (0 when
 * the sample fails). */
double qmc__scene_pdf_brdf(const qmc__scene_geom *g, qmc_vec3 w);
double qmc__scene_pdf_uniform(const qmc__scene_geom *g, qmc_vec3 w);
qmc_vec3 qmc__scene_sample_light(const qmc__scene_geom *g, const double *u, double *dist,
                                 double *pdf);
/* A direction from the BRDF technique and its density (0: the sample
 * failed), from u[0..2). */
qmc_vec3 qmc__scene_sample_brdf(const qmc__scene_geom *g, const double *u, double *pdf);

/* The scene job's audit (qmc_integrand.audit, scene_audit.c). */
uint32_t qmc__scene_audit(const void *ctx, const qmc_result *res);

#endif /* QMC_SCENE_IMPL_H */
