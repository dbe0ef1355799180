/* 3_superquadric impl: owned by its helper until integration */
