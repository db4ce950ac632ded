// DOM shorthands shared by the modules.

export const $ = (id) => document.getElementById(id);

/** Value of the checked radio button of a group. */
export const radio = (name) => document.querySelector(`input[name=${name}]:checked`).value;
