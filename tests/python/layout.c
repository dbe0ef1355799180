/* Prints the layout of every struct examples/python/sqffd.py mirrors with
   ctypes (sizeof, and each field's offset and size), the constants and enum
   values it repeats, as the compiler sees sqffd.h.
   tests/python/test_sqffd.py compares them with the mirrors, so a layout
   change fails the test instead of corrupting memory. Lines:
       struct NAME SIZE
       field NAME.FIELD OFFSET SIZE
       const NAME VALUE */
#include "../../sqffd.h"
#include <stdio.h>

#define STRUCT(type) printf("struct %s %zu\n", #type, sizeof(type))
#define FIELD(type, field) \
    printf("field %s.%s %zu %zu\n", #type, #field, offsetof(type, field), sizeof(((type *)0)->field))
#define CONST(name) printf("const %s %ld\n", #name, (long)(name))

int main(void)
{
    STRUCT(sqffd_points);
    FIELD(sqffd_points, xyz);
    FIELD(sqffd_points, count);
    FIELD(sqffd_points, stride);
    FIELD(sqffd_points, type);

    STRUCT(sqffd_sq_fit_options);
    FIELD(sqffd_sq_fit_options, cost);
    FIELD(sqffd_sq_fit_options, optimizer);
    FIELD(sqffd_sq_fit_options, taper);
    FIELD(sqffd_sq_fit_options, shape_min);
    FIELD(sqffd_sq_fit_options, shape_max);
    FIELD(sqffd_sq_fit_options, taper_max);
    FIELD(sqffd_sq_fit_options, max_iterations);
    FIELD(sqffd_sq_fit_options, tolerance);
    FIELD(sqffd_sq_fit_options, final_points);
    FIELD(sqffd_sq_fit_options, robust);
    FIELD(sqffd_sq_fit_options, robust_rounds);
    FIELD(sqffd_sq_fit_options, progress);
    FIELD(sqffd_sq_fit_options, progress_user);

    STRUCT(sqffd_superquadric);
    FIELD(sqffd_superquadric, size);
    FIELD(sqffd_superquadric, shape);
    FIELD(sqffd_superquadric, taper);
    FIELD(sqffd_superquadric, rotation);
    FIELD(sqffd_superquadric, center);

    STRUCT(sqffd_sq_fit_report);
    FIELD(sqffd_sq_fit_report, iterations);
    FIELD(sqffd_sq_fit_report, cost);
    FIELD(sqffd_sq_fit_report, rms_radial);
    FIELD(sqffd_sq_fit_report, start);
    FIELD(sqffd_sq_fit_report, converged);
    FIELD(sqffd_sq_fit_report, inlier_fraction);
    FIELD(sqffd_sq_fit_report, best_start);
    FIELD(sqffd_sq_fit_report, fallback);

    STRUCT(sqffd_ffd);
    FIELD(sqffd_ffd, dims);
    FIELD(sqffd_ffd, origin);
    FIELD(sqffd_ffd, edges);
    FIELD(sqffd_ffd, inverse);
    FIELD(sqffd_ffd, control);

    STRUCT(sqffd_model);
    FIELD(sqffd_model, sq);
    FIELD(sqffd_model, ffd);
    FIELD(sqffd_model, grid);

    STRUCT(sqffd_fit_options);
    FIELD(sqffd_fit_options, sq);
    FIELD(sqffd_fit_options, lattice);
    FIELD(sqffd_fit_options, box_margin);
    FIELD(sqffd_fit_options, grid);
    FIELD(sqffd_fit_options, alpha);
    FIELD(sqffd_fit_options, tether);
    FIELD(sqffd_fit_options, regularization);
    FIELD(sqffd_fit_options, solver);
    FIELD(sqffd_fit_options, max_iterations);
    FIELD(sqffd_fit_options, coarse_iterations);
    FIELD(sqffd_fit_options, tolerance);
    FIELD(sqffd_fit_options, min_jacobian);
    FIELD(sqffd_fit_options, model_to_data);
    FIELD(sqffd_fit_options, sq_max_points);
    FIELD(sqffd_fit_options, ffd_max_points);
    FIELD(sqffd_fit_options, progress);
    FIELD(sqffd_fit_options, progress_user);

    STRUCT(sqffd_distance_stats);
    FIELD(sqffd_distance_stats, rms);
    FIELD(sqffd_distance_stats, mean);
    FIELD(sqffd_distance_stats, max);
    FIELD(sqffd_distance_stats, diagonal);
    FIELD(sqffd_distance_stats, rms_relative);
    FIELD(sqffd_distance_stats, mean_relative);
    FIELD(sqffd_distance_stats, max_relative);

    STRUCT(sqffd_fit_report);
    FIELD(sqffd_fit_report, sq);
    FIELD(sqffd_fit_report, sq_error);
    FIELD(sqffd_fit_report, error);
    FIELD(sqffd_fit_report, coarse_iterations);
    FIELD(sqffd_fit_report, iterations);
    FIELD(sqffd_fit_report, converged);
    FIELD(sqffd_fit_report, step);
    FIELD(sqffd_fit_report, history_count);
    FIELD(sqffd_fit_report, history);
    FIELD(sqffd_fit_report, energy);
    FIELD(sqffd_fit_report, energy_history);
    FIELD(sqffd_fit_report, min_jacobian);
    FIELD(sqffd_fit_report, stop);

    STRUCT(sqffd_track_options);
    FIELD(sqffd_track_options, fit);
    FIELD(sqffd_track_options, frame_iterations);
    FIELD(sqffd_track_options, progress);
    FIELD(sqffd_track_options, progress_user);

    STRUCT(sqffd_motion_options);
    FIELD(sqffd_motion_options, ed_frame);
    FIELD(sqffd_motion_options, low_motion_fraction);
    FIELD(sqffd_motion_options, hypokinetic_share);
    FIELD(sqffd_motion_options, apex_fraction);
    FIELD(sqffd_motion_options, apex_direction);
    FIELD(sqffd_motion_options, septum_direction);
    FIELD(sqffd_motion_options, stacks);

    STRUCT(sqffd_motion_outputs);
    FIELD(sqffd_motion_outputs, volumes);
    FIELD(sqffd_motion_outputs, trajectories);
    FIELD(sqffd_motion_outputs, displacement);
    FIELD(sqffd_motion_outputs, excursion);
    FIELD(sqffd_motion_outputs, low_motion);
    FIELD(sqffd_motion_outputs, segment);

    STRUCT(sqffd_segment_motion);
    FIELD(sqffd_segment_motion, area);
    FIELD(sqffd_segment_motion, mean_displacement);
    FIELD(sqffd_segment_motion, mean_excursion);
    FIELD(sqffd_segment_motion, low_motion_share);
    FIELD(sqffd_segment_motion, hypokinetic);

    STRUCT(sqffd_motion_report);
    FIELD(sqffd_motion_report, ed_frame);
    FIELD(sqffd_motion_report, es_frame);
    FIELD(sqffd_motion_report, edv);
    FIELD(sqffd_motion_report, esv);
    FIELD(sqffd_motion_report, ejection_fraction);
    FIELD(sqffd_motion_report, axis);
    FIELD(sqffd_motion_report, apex);
    FIELD(sqffd_motion_report, length);
    FIELD(sqffd_motion_report, anterior);
    FIELD(sqffd_motion_report, septum);
    FIELD(sqffd_motion_report, apex_fraction);
    FIELD(sqffd_motion_report, median_excursion);
    FIELD(sqffd_motion_report, segments);

    STRUCT(sqffd_stack);
    FIELD(sqffd_stack, axis);
    FIELD(sqffd_stack, planes);
    FIELD(sqffd_stack, level);
    FIELD(sqffd_stack, spacing);

    STRUCT(sqffd_slice_shifts);
    FIELD(sqffd_slice_shifts, axis);
    FIELD(sqffd_slice_shifts, slices);
    FIELD(sqffd_slice_shifts, level);
    FIELD(sqffd_slice_shifts, shift);
    FIELD(sqffd_slice_shifts, tolerance);

    STRUCT(sqffd_wall_options);
    FIELD(sqffd_wall_options, dysfunctional_thickening);
    FIELD(sqffd_wall_options, stacks);
    FIELD(sqffd_wall_options, endo_stacks);

    STRUCT(sqffd_wall_outputs);
    FIELD(sqffd_wall_outputs, myocardium);
    FIELD(sqffd_wall_outputs, thickness_ed);
    FIELD(sqffd_wall_outputs, thickness_es);
    FIELD(sqffd_wall_outputs, thickening);

    STRUCT(sqffd_segment_wall);
    FIELD(sqffd_segment_wall, thickness_ed);
    FIELD(sqffd_segment_wall, thickness_es);
    FIELD(sqffd_segment_wall, thickening);
    FIELD(sqffd_segment_wall, dysfunctional);

    STRUCT(sqffd_wall_report);
    FIELD(sqffd_wall_report, myocardium_ed);
    FIELD(sqffd_wall_report, myocardium_es);
    FIELD(sqffd_wall_report, thickness_ed);
    FIELD(sqffd_wall_report, thickness_es);
    FIELD(sqffd_wall_report, thickening);
    FIELD(sqffd_wall_report, measured);
    FIELD(sqffd_wall_report, unmeasured);
    FIELD(sqffd_wall_report, segments);

    /* sizes of the enums the mirrors hold as C int */
    STRUCT(sqffd_result);
    STRUCT(sqffd_sq_cost);
    STRUCT(sqffd_sq_optimizer);
    STRUCT(sqffd_regularization);
    STRUCT(sqffd_solver);
    STRUCT(sqffd_scalar);

    CONST(SQFFD_MAX_LATTICE);
    CONST(SQFFD_FIT_HISTORY);
    CONST(SQFFD_SEGMENTS);
    CONST(SQFFD_STACK_PLANES);
    CONST(SQFFD_RESULT_COUNT);
#define PRINT_RESULT(name, text) CONST(name);
    SQFFD_RESULT_LIST(PRINT_RESULT)
#undef PRINT_RESULT
    CONST(SQFFD_STAGE_SUPERQUADRIC);
    CONST(SQFFD_STAGE_FFD);
    CONST(SQFFD_STAGE_FRAME);
    CONST(SQFFD_STAGE_COARSE);
    CONST(SQFFD_SQ_COST_SOLINA);
    CONST(SQFFD_SQ_COST_RADIAL);
    CONST(SQFFD_SQ_OPTIMIZER_LM);
    CONST(SQFFD_SQ_OPTIMIZER_CG);
    CONST(SQFFD_REG_DISPLACEMENT);
    CONST(SQFFD_REG_POSITION);
    CONST(SQFFD_SOLVER_CHOLESKY);
    CONST(SQFFD_SOLVER_SVD);
    CONST(SQFFD_SCALAR_DOUBLE);
    CONST(SQFFD_SCALAR_FLOAT);
    return 0;
}
