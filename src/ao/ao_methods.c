/* ao_methods.c: the method registry (ao.h, "The method registry"). One line per technique; the
 * order is the order of `obscura ao --list` and of the study. */
#include "ao.h"
#include "ao_internal.h"

#include <string.h>

static const ao_method *const methods[] = {
    &ao_i_method_crytek,
    &ao_i_method_alchemy,
    &ao_i_method_sao,
    &ao_i_method_hbao,
    &ao_i_method_ue4,
    &ao_i_method_gtao,
    &ao_i_method_mssao,
    &ao_i_method_mssao_seed,
    NULL,
};

const ao_method *const *ao_methods(void) { return methods; }

const ao_method *ao_method_find(const char *name)
{
    if (!name)
        return NULL;
    for (const ao_method *const *m = methods; *m; m++)
        if (!strcmp((*m)->name, name))
            return *m;
    return NULL;
}

const ao_param_desc *ao_method_param(const ao_method *m, const char *name)
{
    if (!m || !name)
        return NULL;
    for (int i = 0; i < m->param_count; i++)
        if (!strcmp(m->params[i].name, name))
            return &m->params[i];
    return NULL;
}
