/* Compiles: each typed handle goes where its type is wanted. */
#include "corvid/command_list.h"

void record(cv_command_list *l, cv_buffer b, cv_texture t);
void record(cv_command_list *l, cv_buffer b, cv_texture t) {
    cv_cmd_copy_buffer_to_texture(l, CV_QUEUE_COPY, &(cv_copy_buffer_to_texture_args){ .src = b, .dst = t });
}
